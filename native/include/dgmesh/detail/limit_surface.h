/// \file
/// The Loop limit surface of a control mesh through OpenSubdiv (thesis 6.4; see multires.cpp's notes):
/// the control topology refined adaptively, box-spline patches and Gregory-triangle end caps, every
/// patch point as a combination of control vertices, patch lookup by (control face, s, t), and the
/// closest-point search of a point on the surface. Everything that does not depend on positions;
/// used by the multiresolution layer (multires.cpp). Not part of the library's interface.
#pragma once
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/topologyRefiner.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/types.h"

namespace dgmesh::detail {

namespace Far = OpenSubdiv::Far;

constexpr int kMaxCvs = 20;
/// Patch points padded to 4 doubles per row: 32-byte rows that SSE2/AVX handle as whole packets.
using MatX4d = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>;

/// (s, t) clamped into the triangle s, t >= 0, s + t <= 1.
inline void clamp_st(double& s, double& t) {
  s = std::clamp(s, 0.0, 1.0);
  t = std::clamp(t, 0.0, 1.0);
  if (s + t > 1) {
    const double k = 1 / (s + t);
    s *= k;
    t *= k;
  }
}

/// A location on the limit surface: control face and (s, t).
struct Loc {
  int f;
  double s, t;
};

/// The Loop limit surface of a control topology: everything that does not depend on positions.
struct LimitSurface {
  int n_control = 0;
  MatX3i F;
  Topology topo;
  std::unique_ptr<Far::TopologyRefiner> refiner;
  std::unique_ptr<const Far::PatchTable> patches;
  std::unique_ptr<Far::PatchMap> map;
  std::vector<int> ptex;  // ptex face of each control face
  /// Every patch point (control vertex, refined vertex of some level or end-cap local point) that a
  /// patch uses, as a combination of control vertices (CSR row per point). Points are numbered by
  /// first use in patch order and patch_cvs refers to this numbering.
  int n_points = 0;
  std::vector<int> st_off, st_idx;
  std::vector<double> st_w;
  std::vector<int> patch_cvs;  // the patch table's flat patch-point index table
  /// OpenSubdiv 3.5 multiplies the second derivatives of rotated triangular sub-patches by the sign
  /// that only the first derivatives need; init() detects it (by finite differences) and we undo it.
  bool flip_rotated_second = false;

  void init(const MatX3i& F_, int n_vertices, int level);

  /// All patch points for control positions X.
  /// Double-precision patch points, for evaluate() and the closest-point search.
  void points_exact(const MatX3d& X, MatX4d& P) const {
    P.resize(n_points, 4);
#pragma omp parallel for schedule(static)
    for (int r = 0; r < n_points; ++r) {
      Vec3 acc = Vec3::Zero();
      for (int k = st_off[r]; k < st_off[r + 1]; ++k) acc += st_w[k] * X.row(st_idx[k]).transpose();
      P.row(r) << acc.transpose(), 0.0;
    }
  }

  const Far::PatchTable::PatchHandle* handle(int f, double s, double t) const {
    clamp_st(s, t);
    return map->FindPatch(ptex[f], s, t);
  }

  /// Basis weights of the patch under (f, s, t): positions, first derivatives w.r.t. (s, t) and, if
  /// wSS is given, second derivatives (their availability is returned in *second). Returns the
  /// number of patch points (0 if none), whose indices go to cvs.
  ///
  /// Two corrections to OpenSubdiv 3.5's EvaluateBasis: (1) rotated triangular sub-patches get their
  /// second derivatives with a wrong sign (flip_rotated_second); (2) Gregory end caps return pseudo
  /// derivatives that ignore the rational blending (OSD's default unless built with
  /// OPENSUBDIV_GREGORY_EVAL_TRUE_DERIVATIVES), off by a few percent: the projection then stalls and
  /// the normal tilts. There the first derivatives are finite differences of the exact position
  /// weights within the same patch, and no second derivatives are offered.
  int basis(int f, double s, double t, const int*& cvs, double* wP, double* wS, double* wT, double* wSS = nullptr,
            double* wST = nullptr, double* wTT = nullptr, bool* second = nullptr) const;

  /// Double-precision limit position and derivatives w.r.t. (s, t) from patch points P; second
  /// derivatives too when H is given (Suu, Suv, Svv); returns false if there is no patch. *second
  /// tells whether H was filled.
  bool eval(const MatX4d& P, const Loc& l, Vec3& S, Vec3& Ss, Vec3& St, Vec3* H = nullptr,
            bool* second = nullptr) const;

  /// Moves l by the parameter step (ds, dt). A step leaving the face continues into the neighbour
  /// across the edge (the two triangles unfolded into a parallelogram, barycentric coordinates
  /// carried by the shared corners); on a boundary edge it slides along the edge.
  Loc advance(Loc l, double ds, double dt) const;

  /// Local minimum of f = |p - S(s,t)|^2 / 2 from `loc`: Newton with second derivatives (Gauss-Newton
  /// crawls where the distance approaches the radius of curvature), Gauss-Newton where the Hessian is
  /// not positive definite, step halving, walking across faces. d2 gets the final |p - S|^2.
  Loc newton(const MatX4d& P, const Vec3& p, Loc loc, int iterations, double& d2) const;

  /// Closest point of p on the limit surface near `start`. A search that ends on an edge or at a
  /// corner of its face (where the parameter directions of the neighbours do not unfold well) is
  /// restarted inside every face sharing that edge or corner; the nearest result wins. Never returns
  /// a point farther than the start.
  Loc project(const MatX4d& P, const Vec3& p, Loc loc, int iterations) const;

  size_t memory_bytes() const {
    return (st_off.size() + st_idx.size() + patch_cvs.size() + ptex.size()) * sizeof(int) +
           st_w.size() * sizeof(double);
  }
};

}  // namespace dgmesh::detail
