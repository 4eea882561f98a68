// Low-stretch UV unwrapping by stretch equalization (thesis chapter 5) and the parameterization
// distortion metrics of thesis 5.3.
//
// unwrap() maps one chart (a connected triangle mesh of genus 0 with at least one boundary loop)
// to the plane: the initial map U0 fixes the largest boundary loop on a convex polygon and places
// every other vertex by a convex-combination solve (eq. 5.2-5.3); each equalization step divides
// the weights by the vertex stretch (eq. 5.1, 5.4, 5.6) and solves again. Inner boundary loops
// (holes) are filled by a virtual fan for the solves, so they stay open and Tutte's theorem still
// applies (thesis 5.5, first option). Beyond the thesis, a final direct minimisation of eq. 5.5
// with an injectivity barrier (UnwrapOptions::stretch_iterations, uv_stretch_opt.h) starts from the
// chosen map.
#pragma once
#include <string>
#include <vector>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

using MatX2d = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

// A UV triangle has "zero area" when |A(U)| <= this * sum |A(U)| (the metrics' default).
inline constexpr double kZeroAreaEps = 1e-10;

enum class UvBoundary {
  Square,  // unit square, corners placed so that no triangle or chord lies on one side
  Circle,  // circle, arc-length spaced
  Free,    // natural boundary of the least-squares conformal map (LSCM = DCP's natural boundary)
};

enum class UvWeights {
  Floater,    // Floater's shape-preserving weights [Flo97] (the thesis's)
  MeanValue,  // mean-value weights [Flo03]
  Cotangent,  // harmonic (cot a + cot b) weights; may be negative, so U0 may flip
  Uniform,    // Tutte's barycentric weights
  // Beyond the thesis: Cotangent (the harmonic map, closest to conformal, equalizes to a lower
  // stretch than Floater's start on the CGAL disk scans; bench unwrap_quality) and, as soon as a
  // map of it folds or if the result has zero-area triangles, Floater (positive: no flips on a
  // convex polygon) from the start again; mean-value weights for a chart with holes (thesis 5.5).
  // The default.
  Auto,
};

enum class UvSolver {
  Auto,       // UMFPACK up to 1000 unknowns (exact, milliseconds), else Multigrid (faster above)
  Umfpack,    // SuiteSparse UMFPACK LU, symbolic analysis reused across steps
  SparseLU,   // Eigen SparseLU, symbolic analysis reused across steps
  BiCGSTAB,   // Eigen BiCGSTAB + ILUT, warm-started from the previous map
  Multigrid,  // BiCGSTAB preconditioned by smoothed-aggregation multigrid, warm-started
};

// Distortion of a parameterization (thesis 5.3). Stretch follows Sander et al. [SSGH01] with the
// UV map scaled to the surface's area, so 1 is the optimum; flipped triangles are measured with
// their absolute area and counted in `flipped`; a zero-area UV triangle has infinite stretch.
struct UvMetrics {
  double stretch_l2 = 0;         // eq. 5.5 (inf if any UV triangle has zero area)
  double stretch_linf = 0;       // max over triangles of the largest singular value
  double stretch_l2_finite = 0;  // eq. 5.5 over the triangles with non-zero UV area
  double edge = 0;               // sum | |p_i-p_j| / sum|p| - |u_i-u_j| / sum|u| | over edges
  double angle = 0;              // 1/(3F) sum |theta - phi| (radians)
  double area = 0;               // sum | A(T) / sum A(T) - A(U) / sum A(U) |
  int flipped = 0;               // UV triangles oriented against the chart's total orientation
  int zero_area = 0;             // |A(U)| <= zero_area_eps * sum |A(U)|
};

// Metrics of vertex UVs (n x 2) on the triangles F. Edges are the unique undirected edges of F.
// Throws MeshError on wrong sizes, indices out of range or non-finite values.
UvMetrics uv_metrics(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps = kZeroAreaEps);

// Per-triangle Sander stretch sqrt((Gamma^2 + gamma^2) / 2) with the area normalisation of
// uv_metrics (inf for zero-area UV triangles).
VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps = kZeroAreaEps);

// The same with UVs indexed apart from the vertices: corner k of triangle f has UV row FUV(f, k)
// (UVs per face corner, e.g. a Blender UV map with seams, without building a triangle soup).
VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i& FUV,
                      double zero_area_eps = kZeroAreaEps);

// Per-vertex stretch of eq. 5.1: sqrt(sum A(T) sigma(U)^2 / sum A(T)) over the incident triangles.
VecXd uv_vertex_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps = kZeroAreaEps);

// The defaults give the lowest L2 stretch without failed triangles on the CGAL disk scans (bench
// unwrap_quality: free boundary, Auto weights, eta 0.5, sliding boundary; on 10 of 10 models at or
// below every peer measured, at 1.5-3.5x the time of the thesis's setting, bench unwrap_speed).
// The thesis's own setting is unwrap_thesis_defaults().
struct UnwrapOptions {
  UvBoundary boundary = UvBoundary::Free;
  UvWeights weights = UvWeights::Auto;
  double eta = 0.5;               // exponent of eq. 5.6, 0 < eta <= 1
  int iterations = -1;            // -1: Uopt (stop when eq. 5.5 stops decreasing); k >= 0: exactly k steps
  int max_iterations = 100;       // cap for Uopt
  double min_improvement = 1e-3;  // Uopt also stops after a step improving eq. 5.5 by less than this (relative)
  UvSolver solver = UvSolver::Auto;
  // Relative residual of the iterative solve of U0, as the thesis (5.3). A step whose inexact map
  // has flipped triangles is re-solved 100 times tighter, twice at most (the exact map has none on
  // a convex polygon).
  double tolerance = 1e-6;
  // Relative residual of the iterative solves of the equalization steps (U0 and a step re-judged
  // before Uopt stops use `tolerance`): each step only feeds the next step's weights.
  double step_tolerance = 1e-4;
  double zero_area_eps = kZeroAreaEps;
  // Triangle stretches above this are clipped in eq. 5.1 so that a near-degenerate scan triangle
  // (a 3D sliver) cannot dominate the stretch of its vertices.
  double stretch_cap = 1e3;
  // Beyond the thesis (whose boundary stays fixed): every step also slides the outer boundary
  // vertices along the polygon by the same stretch equalization in one dimension (the square's
  // corners stay). The polygon keeps its shape, so Tutte's guarantee still holds.
  bool slide_boundary = true;
  // Beyond the thesis: a final direct minimisation of eq. 5.5 (Sander's L2 stretch) with an
  // injectivity barrier, warm-started from the chosen map (projected Newton with a flip-free line
  // search, free boundary; uv_stretch_opt.h): at most this many Newton steps, 0 = off. Kept only
  // when it lowers eq. 5.5 with no flipped or zero-area triangle; it runs only from a map that has
  // none (a warning otherwise). Its map is the last entry of UnwrapResult::steps.
  int stretch_iterations = 4;
  // The minimisation stops when a Newton step lowers eq. 5.5 by less than this (relative), >= 0.
  double stretch_tolerance = 1e-4;
};

// The thesis's setting (chapter 5): the unit square, Floater's weights, eta 1, the boundary fixed.
inline UnwrapOptions unwrap_thesis_defaults() {
  UnwrapOptions o;
  o.boundary = UvBoundary::Square;
  o.weights = UvWeights::Floater;
  o.eta = 1.0;
  o.slide_boundary = false;
  o.stretch_iterations = 0;
  return o;
}

struct UnwrapStep {
  // Every step carries all metrics of thesis 5.3 (edge and angle included).
  UvMetrics metrics;
  double seconds = 0;         // wall time of this step (solve + metrics)
  int solver_iterations = 0;  // BiCGSTAB iterations (u and v together for the multigrid; 0 for direct solvers)
};

struct UnwrapResult {
  MatX2d uv;          // the chosen map, in [0,1]^2
  MatX2d uv_initial;  // U0 (eq. 5.2-5.3), the start of the equalization
  // steps[h] is U^h (U0 first); Uopt's last entry may be the rejected step; the map of the final
  // stretch minimisation (options.stretch_iterations), when kept, is the last entry (its
  // solver_iterations: the Newton steps) and stretch_step its index.
  std::vector<UnwrapStep> steps;
  int chosen = 0;         // index into steps of the returned map
  int stretch_step = -1;  // index into steps of the stretch minimisation's map; -1: off, not kept or not run
  UvBoundary boundary_used = UvBoundary::Square;
  bool boundary_convex = true;  // the fixed polygon is convex (Tutte: no flips)
  int n_holes = 0;              // inner boundary loops kept open
  std::vector<int> corners;     // square corners (vertex ids), counter-clockwise from (0,0)
  std::vector<std::string> warnings;
  std::string solver;  // solver used
};

// Throws MeshError when the input is not a single chart of disk topology (closed, several
// components, handles), SolverError when a linear system cannot be solved, CancelledError when the
// progress callback returns false.
UnwrapResult unwrap(const MatX3d& V, const MatX3i& F, const UnwrapOptions& options = {},
                    const ProgressFn& progress = {});

// Every chart of a mesh in one call: the triangles with label c (0 <= c < k, every label used)
// form chart c, unwrapped by unwrap() on its own, with its vertices numbered in increasing order of
// their index in V and its triangles in the order of F, so each chart's map is exactly the one
// unwrap() gives for that chart alone. Charts may share vertices (e.g. segments of one mesh): the
// UVs are per triangle corner.
struct UnwrapChartsResult {
  MatX2d uv;                         // row 3f + k: UV of corner k of triangle f in its chart's map
  std::vector<UnwrapResult> charts;  // charts[c]: unwrap() of chart c (uv per chart vertex)
};

// unwrap_charts() could not unwrap one chart: unwrap()'s MeshError for it (`reason`), the message
// naming the chart: "chart c of k (n triangles): reason" (c from 1).
struct UnwrapChartError : MeshError {
  UnwrapChartError(int chart, int n_charts, int n_triangles, const std::string& reason);
  int chart;           // from 0
  std::string reason;  // unwrap()'s message
};

// Throws MeshError for labels of the wrong size, negative or unused, or indices out of range;
// UnwrapChartError when a chart is not of disk topology (the first such chart: nothing is
// returned), SolverError and CancelledError as unwrap(). Progress runs over the charts in
// proportion to their triangles.
UnwrapChartsResult unwrap_charts(const MatX3d& V, const MatX3i& F, const VecXi& labels,
                                 const UnwrapOptions& options = {}, const ProgressFn& progress = {});

// Connected components of n items linked by `pairs` (union-find). Labels are 0..k-1 in order of
// first appearance. Used by the add-on to split meshes into charts along seams.
VecXi connected_labels(int n, const MatX2i& pairs);

}  // namespace dgmesh
