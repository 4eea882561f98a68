/// \file
/// Direct minimisation of Sander et al.'s L2 stretch [SSGH01] (thesis eq. 5.5, as uv_metrics
/// measures it) with an injectivity barrier, warm-started from a flip-free map (unwrap()'s Uopt).
/// The final stage of unwrap() (UnwrapOptions::stretch_iterations); not part of the library's
/// interface.
///
/// With J_T the 2x2 Jacobian of the affine map of triangle T (3D, in an orthonormal frame of T's
/// plane) to its UV triangle, eq. 5.5 squared is L2^2 = P Q / A^2 with A = sum A(T), the UV area
/// P = sum A(T) det J_T and Q = sum A(T) |J_T^{-1}|_F^2 / 2 (Sander's per-triangle
/// (Gamma^2 + gamma^2) / 2). L2 does not change when the map is scaled, and min over scales of P + Q
/// is 2 sqrt(P Q), so minimising the sum of the per-triangle energies
///     E = sum A(T) ( |J_T|_F^2 / (2 det(J_T)^2) + det J_T )
/// over the map minimises L2; |J^{-1}|^2 grows without bound as det J -> 0, a barrier against
/// flips. The minimisation is projected Newton (Teran et al. 2005; Smith & Schaefer 2015 for the
/// flip-free step bound): each triangle's 4x4 Hessian in J is projected onto the positive
/// semi-definite cone, the assembled system is solved by sparse Cholesky, and the step is at most
/// 0.8 of the largest one keeping every UV triangle's signed area positive (roots of a quadratic
/// per triangle), then halved until E decreases (Armijo). The boundary is free. After every step
/// the map is rescaled to the optimal scale (P = Q, where P + Q = 2 A L2).
/// uv_metrics calls a UV triangle of at most 1e-10 of the total UV area "zero-area", and an
/// isometric map gives a scan's 3D sliver such an area; so E also holds a barrier
/// b(a) = -k (a - a0)^2 log(a / a0) on every UV triangle area a below a0 = 1e-9 A (C2, +inf at 0;
/// the IPC barrier's form, Li et al. 2020), which keeps it above that threshold.
/// Convergence: a step lowering L2 by less than `tolerance` (relative) ends the minimisation.
#pragma once
#include <string>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::detail {

struct StretchOptOptions {
  // Defaults: UnwrapOptions' stretch_iterations and stretch_tolerance (the one contract).
  int iterations = UnwrapOptions{}.stretch_iterations;   // Newton steps at most (>= 0; 0 returns the start)
  double tolerance = UnwrapOptions{}.stretch_tolerance;  // stop when a step lowers L2 by less than this, relative
};

struct StretchOptResult {
  MatX2d uv;             // the optimised map (same orientation and bounding box centre as the start)
  int iterations = 0;    // Newton steps taken
  double l2_before = 0;  // eq. 5.5 of the start, over the triangles of non-zero 3D area
  double l2_after = 0;   // eq. 5.5 of the result, the same triangles
  std::string stopped;   // why it stopped: "converged", "iterations", "no descent"
};

/// Pre-conditions: UV (one row per vertex) has every triangle's signed area of the same sign
/// (non-zero): otherwise throws MeshError naming the count. Triangles of zero 3D area carry no
/// energy but their UV triangles are kept positive too. SolverError if the Newton system cannot be
/// factored; CancelledError when progress returns false (fractions 0..1 over `iterations`).
StretchOptResult minimize_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const StretchOptOptions& options,
                                  const ProgressFn& progress = {});

}  // namespace dgmesh::detail
