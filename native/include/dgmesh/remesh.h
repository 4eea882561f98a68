// Remeshing of a disk chart by double parameterization (thesis 5.4), the thesis's version of the
// interactive geometry remeshing of Alliez, Meyer and Desbrun [AMD02] without OpenGL:
//   1. parameterize the chart twice: U0 (Floater, close to conformal) and Uopt (stretch
//      equalization, close to area-preserving), both by unwrap() on the same convex boundary;
//   2. rasterize the area ratio (3D area / UV area), a curvature map and the control map (density)
//      over the sampling map in software, at resolution x resolution pixels;
//   3. sample by error diffusion (serpentine Floyd-Steinberg) of the control map, so that the
//      expected count is the target minus the boundary samples; the boundary is kept (or resampled
//      by 3D arc length at the target spacing);
//   3b. (beyond the thesis's list) relax the samples by a few density-weighted
//      Lloyd steps over the control map's pixels, boundary samples fixed;
//   4. map the samples to the triangulation map through the shared triangulation (same face, same
//      barycentric coordinates), Delaunay-triangulate them there (Qhull) and lift to 3D; a kept
//      boundary's ears (boundary vertices with one triangle, which the unwrap lays out beyond the
//      convex domain) are triangulated apart from the convex rest and joined to it by Delaunay flips
//      across their chords, so the triangulation always has the boundary's edges;
//   4b. (beyond the thesis) 3D Delaunay edge flips and a few sweeps of tangential (optimal-
//      Delaunay) smoothing of the new vertices in the surface metric, moved inside the
//      triangulation map, with removal of stuck valence-3/4 vertices (flip_3d, smooth_iterations):
//      the same post-processing whatever the mode.
// Modes (thesis fig. 5.6-5.9): Double samples on Uopt and triangulates on U0; SingleU0 and
// SingleUopt sample and triangulate on one map.
#pragma once
#include <string>
#include <vector>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"
#include "dgmesh/unwrap.h"

namespace dgmesh {

enum class RemeshMode {
  Double,      // sample on Uopt, Delaunay on U0 (thesis 5.4)
  SingleU0,    // sample and triangulate on U0 (Alliez et al. with a near-conformal map)
  SingleUopt,  // sample and triangulate on Uopt
};

// Metric of the Voronoi cells of the Lloyd relaxation (RemeshOptions::lloyd_iterations).
enum class RemeshRelaxMetric {
  Surface,  // nearest sample in 3D: cells on the surface, whatever the sampling map's distortion
  Map,      // nearest sample in the sampling map (isotropic there, anisotropic on the surface)
};

enum class RemeshBoundary {
  Keep,      // the chart's boundary vertices, exactly and in order (stitchable to the rest)
  Resample,  // new boundary vertices along the boundary polyline, spaced by the local target spacing
};

struct RemeshOptions {
  int target_vertices = 2000;  // total output vertices, boundary included
  double adaptivity = 0.0;     // 0: uniform density; 1: density proportional to curvature
  int resolution = 256;        // raster size of the control map (resolution^2 pixels), 16..4096
  RemeshMode mode = RemeshMode::Double;
  RemeshBoundary boundary = RemeshBoundary::Keep;
  UvBoundary domain = UvBoundary::Circle;  // parameter domain of U0 and Uopt (convex: no flips)
  // Interior samples closer (in 3D) to the boundary polyline than this fraction of the local
  // target spacing are dropped, so the first row of triangles is not made of slivers.
  double boundary_clearance = 0.5;
  double curvature_clip = 8.0;  // curvature density is clipped at this multiple of its mean
  int max_uopt_iterations = 100;
  // The low-stretch map: eq. 5.6's exponent and the number of equalization steps (-1: Uopt, stop
  // when eq. 5.5 stops decreasing; 1: U1, which the thesis finds less anisotropic).
  double eta = 1.0;
  int uopt_steps = -1;
  // Beyond the thesis: after the Delaunay triangulation in the parameter map, flip edges towards a
  // Delaunay triangulation of the 3D mesh (opposite angles summing to more than pi), keeping the
  // embedding in the map, across near-flat edges, where the flip unfolds a fold, or where it raises
  // the smallest angle of a pair holding one under 20 degrees (within 90 degrees of coplanar). Off (with
  // smooth_iterations 0 and lloyd_iterations 0) reproduces the thesis's scheme exactly.
  bool flip_3d = true;
  // Density-weighted Lloyd steps after the error diffusion (Lloyd 1982; the centroidal Voronoi
  // sampling of a parameter map in Alliez et al. 2003, "Isotropic surface remeshing"): each interior
  // sample moves to the control-map mass centroid of its Voronoi cell (in the surface metric: the 3D
  // centroid, within the cell's mean tangent plane, pulled onto the surface), integrated over a grid
  // of the sampling map fine enough for ~32 points a cell (up to 1024^2); boundary samples are fixed
  // generators. At most this many steps: they end when the samples' RMS move falls under 0.3% of
  // the local target spacing (12 steps at 100K vertices, 18-30 at 3000-5000); stopped early, they
  // leave the pattern of the sampling map's error diffusion (isotropic in the map, so stretched on
  // the surface as the map is) in the samples. 0 reproduces the thesis's plain error diffusion.
  int lloyd_iterations = 30;
  // Beyond the thesis: sweeps of tangential smoothing of the new mesh's interior vertices after the
  // triangulation (each vertex towards the area- and density-weighted mean of its triangles' 3D
  // circumcentres, the optimal-Delaunay step of Chen & Xu 2004, moved inside the triangulation map
  // so it stays on the input surface and no map triangle flips; a move may not create a 3D angle
  // below 35 degrees (33 at vertices on sharp features, which only move to lift such an angle), and
  // stars still holding one get a max-min-angle pattern search), each followed by the 3D flips when flip_3d is
  // on and by the removal of interior valence-3/4 vertices whose star holds an angle under 20
  // degrees (RemeshResult::n_removed; the count drops by a few per mille at most), then a closing
  // smoothing sweep on the final connectivity, up to 3 repair rounds (flips, removals, smoothing)
  // restricted to stars still holding an angle below 33 degrees and their neighbours, and flips of
  // the near-flat pairs left non-Delaunay where that lowers no angle.
  // 0: off. The same post-processing for all three modes (bench remesh_quality).
  int smooth_iterations = 3;
  RemeshRelaxMetric relax_metric = RemeshRelaxMetric::Surface;
  // After relaxation, interior samples closer (in 3D) than this fraction of the local target
  // spacing to the boundary or to another kept sample are dropped (0: off).
  double min_separation = 0.35;
};

struct RemeshResult {
  MatX3d V;  // output vertices: the n_boundary boundary vertices first, in loop order
  MatX3i F;  // triangles, oriented like the input
  int n_boundary = 0;
  VecXi boundary_source;  // Keep: input vertex of each boundary vertex; Resample: empty
  MatX2d uv;              // output vertices in the triangulation map
  // Where each output vertex lies on the input: an input face and barycentric weights of its three
  // corners (so callers can carry UVs, weights and other per-vertex or per-corner data over).
  VecXi source_face;
  MatX3d source_bary;
  int n_interior_target = 0;  // expected interior samples (target minus boundary)
  int n_rejected = 0;         // interior samples dropped by the boundary clearance (last pass)
  int passes = 0;             // error-diffusion passes, all rounds (the density is rescaled to hit the count)
  int resolution = 0;         // raster size used: the one asked for, or coarser for small targets
  int sampling_rounds = 0;    // diffusion + relaxation + separation rounds (more when separation drops samples)
  int uopt_iterations = 0;    // equalization steps of Uopt (0 for SingleU0)
  int n_flips = 0;            // 3D Delaunay edge flips (flip_3d)
  int lloyd_iterations = 0;   // Lloyd steps made (fewer than asked when no sample moved)
  int n_separated = 0;        // interior samples dropped by min_separation (last sampling round)
  int smooth_moves = 0;       // vertex moves made by smooth_iterations (all sweeps)
  int n_removed = 0;          // interior vertices of valence 3-4 removed by the smoothing (all sweeps)
  // Wall time of the stages; relax = Lloyd steps + minimum separation (all rounds); triangulate =
  // Delaunay + lift + flips + smoothing.
  double seconds_parameterize = 0, seconds_sample = 0, seconds_relax = 0, seconds_triangulate = 0;
  std::vector<std::string> warnings;
};

// Throws MeshError when the input is not a single chart of disk topology (closed, annulus or
// holes, several pieces, handles), for options out of range, or when target_vertices does not
// exceed the boundary; CancelledError when the progress callback returns false. A triangulation
// that misses the boundary samples (an internal error) is remeshed once more with the boundary
// samples' full clearance, noted in `warnings` (detail/remesh_retry.h).
RemeshResult remesh(const MatX3d& V, const MatX3i& F, const RemeshOptions& options = {},
                    const ProgressFn& progress = {});

// Distance from each point to the triangle mesh (V, F): exact point-triangle distances to the
// candidates whose centroids are the `candidates` nearest to the point (kd-tree), so the result can
// only over-estimate the true distance when a far-centred large triangle is the closest one.
// Used for Hausdorff distances by tests and benchmarks.
VecXd point_mesh_distance(const MatX3d& P, const MatX3d& V, const MatX3i& F, int candidates = 16);

}  // namespace dgmesh
