/// \file
/// Noise level of a mesh, triangle soup or point cloud, for choosing denoising parameters (issue #32).
///
/// The thesis (section 2.3) sets sigma1 from "a standard deviation of the heights of vertices ...
/// for a user-specified flat region"; this estimates the same deviation without a flat region:
/// around every point p a cubic height function
///     h(u, v) = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 + (the four cubic terms)
/// is fitted by least squares to the heights of its `neighbours` nearest points (p included) over
/// the tangent plane of their principal-component normal, with p at the origin. The cubic takes
/// the surface's curvature and its first variation, so on a smooth surface sampled finer than its
/// curvature what is left is the noise (coarse organic meshes are not: see bench/notes/denoise.md).
/// With independent height errors of deviation sigma, p's residual r_p has variance
/// sigma^2 (1 - h_pp), h_pp = [(X^T X)^-1]_00 the leverage of p (X: the design matrix; p is the
/// origin, so its row is (1, 0, ..., 0)): r_p / sqrt(1 - h_pp) ~ N(0, sigma^2) exactly, whatever
/// the number of neighbours and their layout. The estimate is robust:
///     sigma = median_p |r_p / sqrt(1 - h_pp)| / Phi^-1(3/4),   Phi^-1(3/4) = 0.674490,
/// so sharp edges and corners (where a polynomial cannot fit) move it only as far as they move the
/// median. Noise along the normals and isotropic noise (each coordinate N(0, sigma^2)) both give
/// sigma: only the normal component changes a height to first order.
///
/// Detail: the same estimate from wider fits (wide_neighbours(neighbours) points, 36 for 19) reads
/// sigma_wide; noise gives the same value at both widths (the standardised residual is N(0, sigma^2)
/// whatever the fit), while surface detail that a cubic cannot follow grows with the patch, so
///     detail = sqrt(max(0, sigma_wide^2 - sigma^2))
/// measures how much shape the sampling carries below the scale of a 2-ring (large on coarse or
/// highly detailed meshes, near 0 on finely sampled smooth ones). On coarse meshes the small fits
/// miss some of that detail too and read it as noise (no local statistic tells the two apart:
/// bench/notes/denoise.md), which is why the denoising rule weighs sigma against detail.
#pragma once

#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

struct NoiseOptions {
  /// Points of each local fit, the centre included: 19 is a regular mesh's 2-ring. At least 12 (the
  /// cubic has 10 coefficients), at most 64.
  int neighbours = 19;
  /// Points closer than this (relative to the bounding-box diagonal) are one point (a soup's copies
  /// of a vertex); in [0, 0.01).
  double weld_tolerance = 1e-9;
  /// Also run the wide fits that measure `detail` (a second, larger pass); false leaves detail 0.
  bool measure_detail = true;
};

struct NoiseEstimate {
  double sigma = 0;        ///< noise deviation in units of edge_length
  double sigma_abs = 0;    ///< noise deviation in model units (sigma * edge_length)
  double edge_length = 0;  ///< e: mean edge length (meshes) or mean distance to the 6 nearest points (clouds)
  /// Median over the fitted points of e * max |principal curvature| of the fit: how coarse the
  /// sampling is for the surface's bending (0 on a plane; 1 = one edge length per radian).
  double curvature = 0;
  /// Fraction of the fitted points whose standardised residual exceeds 3 sigma: sharp features,
  /// spikes or sampling too coarse for a cubic (Gaussian noise alone gives 0.0027).
  double outliers = 0;
  /// sqrt(max(0, sigma_wide^2 - sigma^2)), in units of edge_length: shape detail at the sampling
  /// scale (see above). 0 when the wide fits are ill-posed (too few points).
  double detail = 0;
  int samples = 0;  ///< points that gave a residual (distinct points with a well-posed fit)
};

/// Points of the wide fits that measure `detail`: 2 neighbours - 2 (36 for 19), at most 64.
int wide_neighbours(int neighbours);

/// Meshes and soups: V (n, 3), F (m, 3) triangles with at least one of positive area; manifoldness
/// is not required and vertices in no face are ignored. Throws MeshError on NaN/inf coordinates,
/// bad indices, no face of positive area, fewer distinct points than `neighbours`, bad options;
/// CancelledError if progress returns false.
NoiseEstimate estimate_noise(const MatX3d& V, const MatX3i& F, const NoiseOptions& opt = {},
                             const ProgressFn& progress = {});

/// Point clouds: V (n, 3); normals are not needed (the fit's frame comes from the neighbours).
NoiseEstimate estimate_noise_points(const MatX3d& V, const NoiseOptions& opt = {}, const ProgressFn& progress = {});

}  // namespace dgmesh
