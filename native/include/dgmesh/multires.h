// Displaced-subdivision multiresolution layer (thesis 6.4 and the end of 6.5, after Lee, Moreton
// and Hoppe 2000, "Displaced subdivision surfaces", [LMH00]).
//
// A dense mesh is represented by a coarse control mesh (quadric decimation of the dense mesh), the
// Loop limit surface of that control mesh (OpenSubdiv 3.5: adaptive refinement, patch table with
// Gregory end caps, evaluated in double precision) and, per dense vertex, a base point on the limit
// surface (control face, s, t) with a displacement in the local frame of the limit surface there:
//   x_i = S(f_i, s_i, t_i) + a_i t1 + b_i t2 + c_i n,   t1 = S_s / |S_s|,  n = S_s x S_t / |...|,
//   t2 = n x t1.
// c is the scalar displacement of DSS along the limit normal; (a, b) is the small tangential residual
// that remains because the base point is a (numerically) closest point, so that the rest pose
// reconstructs exactly. The dense mesh keeps its own topology: only vertex positions are bound.
//
// Deforming the control mesh moves every dense vertex through precomputed stencils: the limit
// position and first derivatives of every dense vertex are ONE sparse product over the control
// vertices (the patch basis composed with OpenSubdiv's patch-point stencils at bind time, ~13
// control vertices per dense vertex, single-precision weights relative to the first one), followed
// by the frame and the displacement, in one parallel pass that writes straight into the output.
// Limit stencils are affine combinations and the frame rotates with the derivatives, so a rigid
// motion of the control mesh moves the dense mesh rigidly.
#pragma once
#include <memory>
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

using MatX2d = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

struct MultiresOptions {
  int control_faces = 5000;  // target face count of the decimated control mesh
  // Adaptive isolation level of the limit patches around extraordinary vertices (1..5) and density
  // of the limit samples that seed the closest-point search (2^level + 1 per control edge).
  int level = 2;
  // Decimation guard against slivers: no collapse may leave the worst triangle around it with a
  // quality 4 sqrt(3) A / (l0^2 + l1^2 + l2^2) below this (unless the worst was already lower).
  double min_quality = 0.2;
  // Least-squares fits of the control vertices so that the limit surface approximates the dense mesh
  // (the optimisation step of [LMH00] that the thesis skipped); each fit is followed by a re-bind.
  // 0 keeps the decimated positions (the thesis's simplified DSS). Around control faces that a fit
  // makes cross each other its step is halved until they do not (a thin tube on few control faces).
  int fit_iterations = 1;
  // Tikhonov weight of the fit, pulling each control vertex towards its decimated position, relative
  // to the mean diagonal of the normal equations (keeps vertices with little data in place).
  double fit_regularization = 1e-3;
  int projection_iterations = 12;  // Gauss-Newton steps of the closest-point projection
};

// The plain arrays that define a binding: enough to rebuild a Multires exactly (from_data).
struct MultiresData {
  MatX3d control_V;  // rest pose of the control mesh
  MatX3i control_F;
  int level = 2;
  VecXi face;   // per dense vertex: control face of its base point
  MatX2d st;    // per dense vertex: (s, t) of its base point, s, t >= 0, s + t <= 1
  MatX3d disp;  // per dense vertex: (a, b, c) in the frame (t1, t2, n)
};

// Where build time went (seconds), for reports and benchmarks.
struct MultiresTimings {
  double decimate = 0, surface = 0, bind = 0, fit = 0, stencils = 0;
};

class Multires {
 public:
  // Decimates the dense mesh to the control mesh, (optionally) fits it, and binds every vertex of
  // the dense mesh. The dense mesh must pass make_mesh(V, F, kSurface); loose vertices are bound too.
  static Multires build(const Mesh& dense, const MultiresOptions& opt, const ProgressFn& progress = {});
  static Multires build(const MatX3d& V, const MatX3i& F, const MultiresOptions& opt, const ProgressFn& progress = {});
  // Binds the points V to the limit surface of a given control mesh (no decimation, no fit).
  static Multires bind(const MatX3d& control_V, const MatX3i& control_F, const MatX3d& V, int level = 2,
                       const ProgressFn& progress = {}, int projection_iterations = 12);
  // Rebuilds a binding from its arrays (validates them; throws MeshError on inconsistent data).
  static Multires from_data(const MultiresData& data);
  MultiresData data() const;

  int n_dense() const;
  int n_control() const;
  int level() const;
  const MatX3d& control_vertices() const;  // rest pose
  const MatX3i& control_faces() const;
  const VecXi& base_face() const;
  const MatX2d& base_st() const;
  const MatX3d& displacement() const;  // (a, b, c) per dense vertex

  // Dense positions for the given control vertex positions (n_control x 3). The other forms write
  // into a caller-owned (n_dense x 3) array, double or single precision (no allocation per call
  // when the array is contiguous; the computation is in double either way).
  MatX3d reconstruct(const MatX3d& control_V) const;
  void reconstruct(const Eigen::Ref<const MatX3d>& control_V, Eigen::Ref<MatX3d> out) const;
  void reconstruct(const Eigen::Ref<const MatX3d>& control_V, Eigen::Ref<MatX3f> out) const;
  // The base points S(f_i, s_i, t_i) of the dense vertices (no displacement) and the limit normals.
  void limit_points(const MatX3d& control_V, MatX3d& points, MatX3d* normals = nullptr) const;
  // Limit positions and first derivatives (w.r.t. s and t) at any locations (face, s, t) of the
  // control mesh, in double precision.
  void evaluate(const MatX3d& control_V, const VecXi& face, const MatX2d& st, MatX3d& P, MatX3d* Ds = nullptr,
                MatX3d* Dt = nullptr) const;
  // Position weights of the dense base points over the control vertices (n_dense x n_control, rows
  // sum to 1): limit_points = W * control_V. For least-squares problems on the control mesh.
  SpMatR limit_matrix() const;

  // Sizes of the precomputed tables (for memory reports) and the build timings.
  int n_patch_points() const;
  size_t memory_bytes() const;
  const MultiresTimings& timings() const;

  struct Impl;

 private:
  explicit Multires(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

}  // namespace dgmesh
