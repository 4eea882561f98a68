// Similarity-based (non-local means) denoising of meshes, triangle soups and point clouds
// (thesis chapter 2), with bilateral mesh denoising (Fleishman et al. 2003) as the baseline.
//
// Only vertex positions, normals and area elements enter the filter, so meshes, soups (faces that
// share no vertices) and point clouds with normals are handled by the same code: coincident
// vertices are welded for the computation and every copy receives the same displacement.
#pragma once
#include <vector>

#include "dgmesh/noise_estimate.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

enum class DenoiseMethod {
  Similarity,  // NL-means with local RBF patches, thesis eq. 2.3-2.9
  Bilateral,   // Fleishman, Drori, Cohen-Or 2003 ([FDCO03])
};

// sigma_i = eta_i * e with e the average edge length of the current mesh (re-evaluated every
// iteration). Similarity: sigma1 = similarity kernel deviation (2.7), 2*sigma2 = radius of the
// averaging domain (2.4), 2*sigma3 = radius of the RBF patch and of the compared neighbourhoods
// (2.8, 2.9). Bilateral (thesis table 2.1 convention): sigma1 = height (range) Gaussian,
// 2*sigma2 = neighbourhood radius, sigma3 = spatial Gaussian.
struct DenoiseOptions {
  DenoiseMethod method = DenoiseMethod::Similarity;
  // true: estimate the noise first (estimate_noise, default NoiseOptions) and run with
  // auto_options(estimate, *this): eta1, iterations and quadratic_fit come from the rule there, the
  // other fields stay as given; similarity on meshes may smooth instead of filtering (see denoise()).
  // false: every field as given (the thesis's manual setting).
  bool automatic = true;
  double eta1 = 0.4;
  double eta2 = 1.0;
  double eta3 = 0.75;
  int iterations = 3;
  // Similarity only. false: k(x) is the similarity-weighted mean of the heights I(y) (eq. 2.4), a
  // local-constant (Nadaraya-Watson) estimate: on a curved surface the heights of the neighbours
  // are not centred on x's (a sphere sampled at edge length e shrinks by about kappa e^2 / 2 per
  // iteration), which dominates on coarse meshes. true: k(x) is c0 of the quadratic
  // h = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 fitted to the same heights with the same weights
  // (local quadratic regression, Fan & Gijbels 1996): exact on any quadratic, so curvature is not
  // read as noise. Falls back to the mean where the weights hold fewer than 2 points per
  // coefficient ((sum W)^2 / sum W^2 < 12) or the fit is singular.
  bool quadratic_fit = false;
  // Meshes only: steps of Taubin's lambda|mu smoothing (Taubin 1995: x += lambda L x, then
  // x += mu L x, lambda = 0.6, mu = -0.62; L the umbrella operator over the mesh edges with weights
  // half uniform, half clamped cotangent of the input positions, normalised per vertex) run
  // before the filter. 0 (the thesis setting): none. Low-pass in 3D, so it also removes the
  // tangential part of isotropic noise, which a filter moving along the normals cannot; it rounds
  // sharp features. Automatic mode sets it (see auto_options and denoise()).
  int smoothing_steps = 0;
  // Vertices allowed to move (empty: all). Masked vertices still inform the filter. Welded copies
  // of one point move only if all of them may move.
  std::vector<char> movable;
  // Point clouds: after the first iteration re-estimate normals by PCA over the 2*sigma2 ball,
  // oriented like the input normals (false: keep the input normals throughout).
  bool reestimate_normals = true;
  // Vertices closer than this (relative to the bounding-box diagonal) are welded.
  double weld_tolerance = 1e-9;
  // Caps on neighbourhood sizes (nearest first), bounding the cost on very non-uniform meshes:
  // points of an RBF patch / compared neighbourhood (<= 64), and points of the averaging domain.
  // 0 = automatic: about 2.5 times what the ball holds on a regular mesh (36 eta^2), at least 12 / 24.
  int max_patch = 0;
  int max_window = 0;
};

// The rule of automatic mode (issue #32; measured in bench/notes/denoise.md): from the noise
// estimate (sigma in units of the mean edge length e, the unit of the etas)
//   similarity: eta1 = k * sqrt(4 pi / sqrt(3)) * eta3 * sigma (k = 1),
//               quadratic_fit = (noise.curvature > sigma): coarse sampling for the surface's bending;
//   bilateral:  eta1 = k_b * sigma (k_b = sqrt(2));
//   eta1 at least 0.001, iterations = 3,
//   smoothing_steps = round(9.5 n^1.8 / d^1.5), at most 60, with d = max(detail, 0.03) and
//               n = sqrt(max(0, sigma^2 - min(0.9 d, 0.1)^2)) (meshes; the best Taubin step count
//               grows with the noise and falls with the shape detail that the sampling carries,
//               which smoothing destroys; a noise-free coarse scan's estimate reads sigma of
//               0.4-0.85 d and at most about 0.1 e, its shape at the sampling scale, so only sigma
//               above that floor counts as noise; fitted on the best counts of 14 CGAL models
//               with the Taubin operator of denoise(), bench/notes/denoise.md, session 25),
// and every other field of `base` unchanged (auto_options itself sets smoothing_steps to 0: the
// choice between the two is made by denoise(), below). Noise-free input (sigma -> 0) gives a kernel
// narrower than any difference between neighbourhoods, so the filter leaves it nearly unchanged.
DenoiseOptions auto_options(const NoiseEstimate& noise, const DenoiseOptions& base);

// The automatic Taubin step count of a noise estimate (the smoothing_steps rule above).
int auto_smoothing_steps(const NoiseEstimate& noise);

// The automatic choice's feature test: outliers > max(curvature, 0.05) in the estimate of the
// filtered mesh (creases read as outliers of the smooth local fits).
bool shows_features(const NoiseEstimate& noise);

// Defaults of the bilateral filter from the thesis's Fandisk setting (table 2.1, [FDCO03]).
DenoiseOptions bilateral_defaults();

// The defaults of a method: DenoiseOptions{} (the thesis's suggested setting, section 2.3) for
// Similarity, bilateral_defaults() for Bilateral.
DenoiseOptions denoise_defaults(DenoiseMethod method);

struct DenoiseResult {
  MatX3d vertices;              // denoised positions, one row per input vertex
  VecXd residual;               // |x_noisy - x_smoothed| per input vertex
  double residual_entropy = 0;  // see residual_entropy()
  double edge_length = 0;       // e of the last iteration
  int iterations = 0;
  long long rbf_fallbacks = 0;  // RBF patches solved by the lower-order (plane) fallback
  int welded = 0;               // vertices merged into a coincident one for the computation
  NoiseEstimate noise;          // automatic mode: the estimate of the input (all zero otherwise)
  DenoiseOptions options;       // the options the filter ran with (automatic: after auto_options)
};

// Automatic mode on meshes with the similarity method chooses between two results: the filter
// with the rule's eta1 (no smoothing) and Taubin smoothing alone with the rule's step count (no
// filter). It runs the filter first and estimates the noise of its output: if that shows sharp
// features (outliers / curvature of the estimate above 1: creases read as outliers against a
// smooth fit, issue #32's fandisk), the filter's result is kept;
// else the input is smoothed instead (coarse organic meshes, where the tuned peers were Laplacian
// smoothers). If the rule asks for no smoothing step (noise small against the shape detail, e.g.
// noise-free input), neither runs and the mesh is returned unchanged. result.options tells which
// ran: smoothing_steps > 0 and iterations 0 for smoothing, both 0 for none.
// Meshes and soups: V (n,3), F (m,3) triangles with at least one non-degenerate face. Manifoldness
// is not required. Vertices in no face do not move. Throws MeshError on NaN/inf, bad indices, a
// mask of the wrong size, bad parameters; CancelledError if progress returns false.
DenoiseResult denoise(const MatX3d& V, const MatX3i& F, const DenoiseOptions& opt, const ProgressFn& progress = {});

// Point clouds with per-point normals N (n,3; need not be unit; zero normals keep the point fixed).
// The area element is estimated from the local density (k nearest neighbours), and e as the edge
// length of the regular triangulation of that density.
DenoiseResult denoise_points(const MatX3d& V, const MatX3d& N, const DenoiseOptions& opt,
                             const ProgressFn& progress = {});

struct SimilarityOptions {
  double eta1 = 0.4;
  double eta3 = 0.75;
  // true: compare shapes only, wherever they are and however they are tilted: y's neighbourhood is
  // expressed in y's own frame (n_y, with x's first tangent carried over onto y's tangent plane),
  // which shows similar features anywhere on the model (thesis fig. 2.1c). false: the filter's own
  // weights w(x, y) of eq. 2.7 (everything in x's frame, heights from x's tangent plane), which
  // vanish away from x.
  bool shape_only = true;
  int max_patch = 0;  // as DenoiseOptions::max_patch
};

// Similarity w(x, y) in [0, 1] of every vertex y to vertex x = `vertex` (eq. 2.7, 2.9); 1 at x.
// Vertices in no face get 0.
VecXd similarity(const MatX3d& V, const MatX3i& F, int vertex, const SimilarityOptions& opt = {},
                 const ProgressFn& progress = {});
VecXd similarity_points(const MatX3d& V, const MatX3d& N, int vertex, const SimilarityOptions& opt = {},
                        const ProgressFn& progress = {});

// Shannon entropy (bits) of the distribution of residual magnitudes: the histogram of r / mean(r)
// over [0, 4) in 64 bins plus one overflow bin, so it is independent of scale (0..log2(65)).
// Non-finite values are ignored; 0 for an empty or all-zero residual.
double residual_entropy(const VecXd& residual);

}  // namespace dgmesh
