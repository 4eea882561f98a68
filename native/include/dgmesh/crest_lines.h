// Crest lines (thesis chapter 4): curvature derivatives by the enhanced adjacent-normal cubic fit
// (4.5, eq. 4.7-4.8), tracing of the zero crossings of the extremality coefficients (4.6, after
// Ohtake-Belyaev-Seidel 2004), gap jumping, and the scale-independent strength T (eq. 4.10-4.11).
// Also the feature distance field F(d) (eq. 4.12) used by decimation (4.8) and segmentation (4.9).
#pragma once
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

// DerivativeOptions::noise_adaptive: the jet fit gives way to the thesis fit when the median residual ratio
// sqrt(v4 / v3) of the 2-ring cubic and quartic height fits exceeds this (calibration:
// bench/notes/crest_derivatives.md).
constexpr double kJetNoiseRatio = 0.5;

struct DerivativeOptions {
  int rings = 1;  // k of the k-ring used for the fit (thesis: 1..4); 1..8 accepted
  // Two-pass jet fit (the default; bench crest_derivatives, issue #31). Pass 1: the normal at every vertex from a jet
  // fitted to the heights of its 2-ring over the Max normal's tangent plane (as Cazals-Pouget jet fitting; degree 4 for
  // one-ring fits, 3 otherwise). Pass 2: a jet with free linear terms fitted at the vertex p itself to the heights of
  // its k-ring and the slopes of their pass-1 normals (the adjacent-normal equations of [GI04] with better normals),
  // degree 3 on the one-ring and 5 on larger rings, so that a wider ring does not bias the third derivatives with the
  // surface's fifth-order terms; a one-ring of fewer than six vertices is widened to the 2-ring. The fields are
  // eq. 4.9 of the fitted graph at p. The four options below then do not apply, unless noise_adaptive falls back to
  // the thesis fit, or crest lines meet a plateau (plateaus). false: the thesis's enhanced adjacent-normal cubic fit
  // of eq. 4.7 (4.5), configured by the four options below.
  bool jet = true;
  // With jet: the jet fit is used only on a mesh that does not look noisy; otherwise the thesis's fit below (the four
  // options) is used, which is less sensitive to noise (its p->p' step averages the one-ring). The test: on at most
  // 2048 vertices spread evenly by index, a cubic and a quartic jet are fitted to the heights of the 2-ring and their
  // residual variances per degree of freedom compared; the median ratio sqrt(v4 / v3) is small when the cubic's
  // residual is truncation error (which a quartic removes) and near 1 when it is noise (which it does not). Above
  // kJetNoiseRatio the thesis fit is used (CurvatureDerivatives::noise_ratio, jet_used). false: the jet fit whatever
  // the noise.
  bool noise_adaptive = true;
  // crest_fields() (and so crest lines) with the jet fit: where the curvature of larger magnitude is constant along its
  // line of curvature to within the jet's own error (its e within five standard errors, or round-off, on a vertex and
  // its whole one-ring: flat regions, G1 blends of constant radius, spheres, surfaces of revolution's parallels), the
  // zero crossings of e carry no information; there, and within the jet's support (rings + 2 rings) of it, where the
  // jet overshoots a jump of k at a plateau's rim, the thesis's fit below is used, whose p->p' step rounds a plateau's
  // ends into a maximum on its middle line (a blend's crest line, as the limit of any symmetric smoothing).
  // curvature_derivatives() does not apply it (its jet e of 0 there is the right value).
  bool plateaus = true;
  bool smooth = true;       // fit on M' (p' = mean of the centroids of the faces around p)
  bool use_normals = true;  // adjacent-normal equations in the fit (thesis table 4.1 "normal")
  // With use_normals: the tangent plane is fitted too. Eq. 4.7 gets the linear terms a0 x + a1 y and
  // the Max normal of p' enters as one more normal equation instead of being imposed exactly, so
  // its O(h^2) error does not bias the curvatures; the derivatives then come from the exact
  // formulas of the graph (non-zero gradient). false: eq. 4.7 as printed (zero gradient at p').
  // Vertices with fewer than five usable neighbours always use eq. 4.7 as printed.
  bool fit_tangent_plane = true;
  // With smooth: evaluate the fitted surface at the foot of the original vertex p (its offset from
  // p' projected on the tangent plane) rather than at p', so the fields belong to p (thesis 4.5
  // "assigned to the original vertices"). Matters on irregular meshes, where p' drifts sideways.
  bool transport_to_vertex = true;
};

// Per original vertex. Curvature signs follow the face orientation: positive on a sphere with
// outward (counter-clockwise) faces. t_max / t_min are unit tangent vectors; e = dk/dt along them
// (its sign flips with t, the product e t is well defined). Loose vertices get zeros.
struct CurvatureDerivatives {
  VecXd k_max, k_min, e_max, e_min;
  MatX3d t_max, t_min, normals;  // normals: of the fitted surface (orthogonal to t_max, t_min)
  // With jet: the median residual ratio of the noise test (DerivativeOptions::noise_adaptive); 0 (no evidence of
  // noise) when fewer than 16 sampled vertices have the 16 neighbours a quartic needs and a cubic residual above
  // round-off (planar and quadric patches of exact meshes); 0 without jet.
  double noise_ratio = 0.0;
  bool jet_used = false;  // the jet fit was used (jet and, with noise_adaptive, noise_ratio <= kJetNoiseRatio)
  // With jet_used: standard errors of e_max, e_min (from the residual of the pass-2 fit; the curvature term of eq. 4.9
  // taken as exact); empty otherwise.
  VecXd e_max_error, e_min_error;
  int plateau_vertices = 0;  // crest_fields(): vertices given the thesis's fit by DerivativeOptions::plateaus
};

// Throws MeshError on invalid options. The mesh must come from make_mesh (validated).
CurvatureDerivatives curvature_derivatives(const Mesh& mesh, const DerivativeOptions& opt,
                                           const ProgressFn& progress = {});

enum CrestKind : int { kRidge = 0, kValley = 1 };  // convex / concave crest lines

struct CrestOptions {
  bool ridges = true;
  bool valleys = true;
  bool join_gaps = true;  // thesis fig. 4.10 gap jumping (alpha, beta <= pi/3, gamma <= pi/2)
  // Ignore edges touching the mesh boundary, where the fit is one-sided and its third derivatives
  // are unreliable.
  bool skip_boundary = true;
  // Keep lines with strength T >= threshold (eq. 4.10); 0 keeps every line. The thesis used
  // T = 1..3 on its own one-ring figures; on CGAL's scans T = 5 still leaves many noise-driven
  // fragments on the bunny, T = 10 keeps the salient lines of fandisk, bunny and armadillo, T = 25
  // only the strongest (bench/images/crest_lines_*.png).
  double threshold = 10.0;
};

struct CrestLines {
  // Crest points. Most lie on a mesh edge (edge_v0, edge_v1) at point = (1-t) v0 + t v1;
  // junction points inside a triangle (three crossings, OBS04) have edge (-1, -1) and t = 0.
  MatX3d points;
  MatX2i point_edge;
  VecXd point_t;
  VecXd point_cyclideness;  // C of eq. 4.11 interpolated as in 4.6
  // Segments between points; segment_face is the triangle holding it (-1 for a gap jump).
  MatX2i segments;
  std::vector<int> segment_line, segment_face;
  // Lines as ordered point lists: points line_points[line_offset[l] .. line_offset[l+1]);
  // a closed line repeats its first point at the end.
  std::vector<int> line_offset{0}, line_points;
  std::vector<int> line_kind;         // CrestKind
  std::vector<double> line_strength;  // T of eq. 4.10 (dimensionless)
  std::vector<double> line_length;

  int n_lines() const { return static_cast<int>(line_kind.size()); }
};

// The fields crest lines are traced on: curvature_derivatives(), then with the jet fit and opt.plateaus the thesis's
// fit at plateau vertices (DerivativeOptions::plateaus).
CurvatureDerivatives crest_fields(const Mesh& mesh, const DerivativeOptions& opt, const ProgressFn& progress = {});

// Traces the crest lines of the fitted fields (no thresholding when opt.threshold <= 0).
CrestLines trace_crest_lines(const Mesh& mesh, const CurvatureDerivatives& d, const CrestOptions& opt);

// crest_fields() plus trace.
CrestLines crest_lines(const Mesh& mesh, const DerivativeOptions& fit, const CrestOptions& opt,
                       const ProgressFn& progress = {});

// The lines with T >= threshold and of the requested kinds, points and segments re-indexed (points
// and segments keep their order).
CrestLines filter_crest_lines(const CrestLines& lines, double threshold, bool ridges = true, bool valleys = true);

// Geodesic distance from every face to the nearest crest line (thesis 4.8): Dijkstra over the face
// graph, the length between two faces sharing an edge being centroid -> edge midpoint -> centroid.
// Faces holding a crest segment are at distance 0. Faces of components without a line get the
// largest finite distance (so they count as far from features); all zeros when there is no line.
VecXd crest_face_distance(const Mesh& mesh, const CrestLines& lines);

// F(d) = (d / max d + eps)^eta of eq. 4.12, per face.
VecXd feature_function(const VecXd& distance, double eta, double eps = 0.1);

// Crest-line guidance of decimation (thesis 4.8: face quadrics weighted by 1 / F(d)) and
// segmentation (4.9: region growing weighted by 2 / (F(T_i) + F(T_j))), F of eq. 4.12 with d the
// distance to the crest lines given by the caller, or else detected with `rings` and `threshold`.
// F(d) spans (1 + 1 / eps)^eta = 11^eta: beyond this eta its weights leave double's range.
constexpr double kMaxFeatureWeight = 100.0;

struct FeatureOptions {
  double feature_weight = 0.0;  // eta of eq. 4.12 in [0, kMaxFeatureWeight]; 0: not guided
  int rings = 1;                // DerivativeOptions::rings of the detected lines
  double threshold = 10.0;      // CrestOptions::threshold of the detected lines
};

// Decimation's: eta = 6, the thesis's fig. 4.19 (bunny decimated by 90%, bench crest_renders).
FeatureOptions decimate_feature_defaults();
// Segmentation's: eta = 2, the thesis's fig. 4.26-4.27 (bunny and Max-Planck in 25 segments).
FeatureOptions segment_feature_defaults();

}  // namespace dgmesh
