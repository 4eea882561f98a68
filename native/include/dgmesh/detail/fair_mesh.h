/// \file
/// The working mesh of the curvature flows and the tangential regularisation (fair.cpp,
/// regularization.cpp): the faces within reach of the movable vertices, validated, with per-level
/// vertex roles, and the original boundary polylines that sliding vertices follow. Not part of the
/// library's interface.
#pragma once
#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include "dgmesh/fair.h"
#include "dgmesh/mesh.h"
#include "dgmesh/types.h"

namespace dgmesh::detail {

/// Below this many elements a loop runs serially. The per-vertex loops are a few hundred
/// flops each; on a loaded 2-core machine, waking (and spin-waiting) OpenMP threads around every
/// small loop slowed a 5K-vertex hole fill from 0.9 s to 17 s, so only large meshes go parallel.
constexpr int kFairParallelMin = 1 << 16;

/// Working state of one level: a validated submesh in normalised coordinates.
struct Work {
  MatX3d P;
  MatX3i F;
  Topology topo;
  std::vector<char> movable;     // per vertex
  std::vector<char> sliding;     // movable boundary vertices (sliding mode)
  std::vector<char> energy_set;  // movable vertices and their neighbours
  std::vector<char> region;      // per face: refined by subdivision
  std::vector<char> near;        // per face: touches a movable vertex (for A_min)
};

/// Sets the vertex roles of a level from w.movable: fixed boundary vertices stop moving (or slide),
/// the energy set and the faces near movable vertices.
void prepare_level(Work& w, FairBoundary boundary);

/// Mean edge length (the unit of the normalised coordinates); 1 without edges.
double mean_edge_length(const MatX3d& P, const Topology& t);

/// The original boundary polylines, onto which sliding vertices are projected.
struct BoundaryCurves {
  std::vector<std::vector<Vec3>> loops;
  std::vector<std::pair<int, int>> hint;  // per vertex: (loop, segment) last found; (-1, -1) unknown

  void build(const Work& w) {
    loops.clear();
    for (const auto& loop : w.topo.boundary_loops) {
      bool any = false;
      for (int v : loop) any |= w.sliding[v] != 0;
      if (!any) continue;
      std::vector<Vec3> pts;
      for (int v : loop) pts.push_back(w.P.row(v).transpose());
      loops.push_back(std::move(pts));
    }
  }
  static Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b, double& d2) {
    const Vec3 ab = b - a;
    const double l2 = ab.squaredNorm();
    const double s = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
    const Vec3 q = a + s * ab;
    d2 = (p - q).squaredNorm();
    return q;
  }
  /// Projects p onto the curves; searches near the hint, or everywhere without one.
  Vec3 project(const Vec3& p, std::pair<int, int>& h) const {
    double best = std::numeric_limits<double>::infinity();
    Vec3 q = p;
    auto try_seg = [&](int l, int s) {
      const auto& L = loops[l];
      const int ns = static_cast<int>(L.size());
      s = ((s % ns) + ns) % ns;
      double d2;
      const Vec3 c = closest_on_segment(p, L[s], L[(s + 1) % ns], d2);
      if (d2 < best) best = d2, q = c, h = {l, s};
    };
    if (h.first >= 0) {
      const auto start = h;
      for (int ds = -4; ds <= 4; ++ds) try_seg(start.first, start.second + ds);
    } else {
      for (int l = 0; l < static_cast<int>(loops.size()); ++l)
        for (int s = 0; s < static_cast<int>(loops[l].size()); ++s) try_seg(l, s);
    }
    return q;
  }
};

/// 1D equalisation of sliding boundary vertices along their boundary, then projection.
void slide_boundary(Work& w, BoundaryCurves& curves, double step);

/// Area-weighted unit vertex normals (eq. 3.7) and face areas, serial below kFairParallelMin.
void area_normals(const MatX3d& P, const MatX3i& F, const Topology& t, MatX3d& N, VecXd& farea, MatX3d& fcross);

/// The input reduced to the faces within reach of the movable vertices and the region.
struct Submesh {
  std::vector<int> verts;  // local -> full vertex
  std::vector<int> faces;  // local -> full face
  Work work;
};

/// The faces touching a vertex that is movable or in a region face, and the faces touching those
/// (every face when `whole`), with local indices and roles. A vertex of the outer ring (fixed) where
/// those faces meet in separate fans gets a copy per further fan, mapped to the same full vertex.
Submesh extract(const MatX3d& V, const MatX3i& F, const std::vector<char>& movable_full,
                const std::vector<char>& region_full, bool whole);

/// MeshError for an empty or invalid input, or masks of the wrong size (fmask may be null).
void check_input(const MatX3d& V, const MatX3i& F, const std::vector<char>& vmask, const std::vector<char>* fmask);

/// validate(w.P, w.F, kSurface), its message saying when the problem is in a region's submesh.
Topology validated_topology(Work& w, bool whole);

}  // namespace dgmesh::detail
