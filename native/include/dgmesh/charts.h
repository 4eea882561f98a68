// One-click unwrap of closed or complex meshes (issue 29): the surface is cut into charts that are
// topological disks once cut open along their own cuts, each chart is unwrapped by the low-stretch
// method of unwrap.h (thesis chapter 5: Uopt and the final stretch minimisation), and the charts
// are laid out side by side in [0,1]^2.
//
// 1. Initial charts: variational shape approximation (segment.h, thesis 4.9: L^{2,1} proxies of the
//    normals, Lloyd iterations), so chart borders run where the normal turns (high curvature).
// 2. Every chart must be a disk: connected, one boundary loop, Euler characteristic V - E + F = 1
//    (chart_is_disk). A sphere with b >= 2 holes (a tube: an open cylinder, a limb's band) is cut
//    open inside the chart along the shortest edge path from one boundary loop to another, b - 1
//    times, so it stays one chart (its seam runs rim to rim). Any other chart that is not a disk
//    (a torus's band, a closed piece) is split in two by a 2-proxy VSA grown inside it from its
//    two mutually farthest faces, and both halves are checked
//    again (with groups, each group goes to the side of its first triangle, and a side that falls
//    apart becomes one chart per connected piece).
// 3. Each disk is unwrapped (unwrap(), free boundary). Then the worst chart is split the same way
//    and only its halves are unwrapped again (the other charts keep their maps), until the whole
//    packed map's L2 stretch (eq. 5.5 over all triangles) is at most target_stretch and no chart is
//    above max_stretch. Worst: a map with a flipped or zero-area triangle first, then a chart above
//    max_stretch, then the chart whose stretch costs the whole map most, A_c (s_c^2 - 1) (every
//    chart is scaled to its 3D area, so the whole map's s^2 is the area-weighted mean of s_c^2).
//    Stretch splits stop at max_charts (a warning).
// 4. Merge: neighbouring charts (in decreasing length of their common border) are joined when the
//    union is a disk whose map has no failed triangle, is within max_stretch, and keeps the whole
//    map within target_stretch (a CAD part's plane and cylinder may share one chart). A union
//    that is a tube is cut open as in step 2.
// 5. Packing: every chart's map is scaled to its 3D area, turned to its smallest bounding box (16
//    angles) and placed on shelves (tallest first) with `margin` between charts; the layout is
//    scaled uniformly into [0,1]^2. Charts never overlap (disjoint boxes); within a chart the
//    map has no flipped triangle.
#pragma once
#include <string>
#include <vector>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"
#include "dgmesh/unwrap.h"

namespace dgmesh {

struct AutoUnwrapOptions {
  // Largest L2 stretch (eq. 5.5, Sander's normalisation, 1 = isometric) any one chart may keep;
  // charts above it are split. > 1; infinity: no bound per chart.
  double max_stretch = 1.5;
  // Initial number of charts (VSA segments) before disks are enforced and stretch splits; >= 1,
  // at most the number of triangles. 0: automatic (8).
  int charts = 0;
  // Largest L2 stretch of the whole packed map (eq. 5.5 over all triangles, the area-weighted root
  // mean square of the charts' own): the worst chart is split until the map is within it. > 1;
  // infinity: no bound.
  double target_stretch = 1.05;
  int max_charts = 2000;  // no stretch split beyond this many charts (>= 1)
  // Merge neighbouring charts while their union is a disk within both bounds (step 4).
  bool merge = true;
  double margin = 0.005;  // gap between packed charts, as a fraction of the layout's side, in [0, 0.25)
  // Triangles that must stay in one chart (the triangles of one polygon): groups[f] >= 0 per
  // triangle, triangles of equal value are never cut apart. Empty: every triangle on its own.
  VecXi groups;
  UnwrapOptions unwrap;  // how each chart is unwrapped (unwrap.h defaults)
};

struct AutoUnwrapResult {
  MatX2d uv;            // (3m, 2) row 3f + k: UV of corner k of triangle f, packed in [0,1]^2
  VecXi chart;          // (m,) chart of each triangle, 0 .. n_charts-1
  MatX2i seams;         // (s, 2) vertex pairs of the cut edges (between two charts or inside one), v0 < v1
  VecXd chart_stretch;  // (n_charts,) L2 stretch of each chart's own map (eq. 5.5)
  UvMetrics metrics;    // of the packed map over all triangles (uv_metrics on the corner UVs)
  int n_charts = 0;
  int initial_charts = 0;   // charts of the VSA segmentation
  int topology_splits = 0;  // splits that made non-disk charts into disks
  int path_cuts = 0;        // charts made disks by cutting paths between their boundary loops
  int stretch_splits = 0;   // splits of charts above max_stretch or target_stretch (or with a failed map)
  int merges = 0;           // pairs of charts merged (step 5)
  double seam_length = 0;   // total 3D length of the seams
  double edge_length = 0;   // total 3D length of all edges
  double uv_area_used = 0;  // sum of the UV triangle areas (the layout is in [0,1]^2: at most 1)
  std::vector<std::string> warnings;
};

// Throws MeshError for input that is not a manifold, consistently oriented triangle mesh without
// zero-area triangles (validate.h kSurface), and for options out of range; SolverError as
// unwrap(); CancelledError when the progress callback returns false.
AutoUnwrapResult auto_unwrap(const MatX3d& V, const MatX3i& F, const AutoUnwrapOptions& options = {},
                             const ProgressFn& progress = {});

// Whether the triangles `faces` of F form a topological disk: connected (across edges), a single
// boundary loop through vertices that each have one fan, and V - E + F = 1.
bool chart_is_disk(const MatX3i& F, const std::vector<int>& faces);

}  // namespace dgmesh
