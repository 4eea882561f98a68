// One-click unwrap of closed or complex meshes (issue 29): the surface is cut into charts that are
// topological disks, each chart is unwrapped by the low-stretch method of unwrap.h (thesis chapter
// 5: Uopt and the final stretch minimisation), and the charts are laid out side by side in [0,1]^2.
//
// 1. Initial charts: variational shape approximation (segment.h, thesis 4.9: L^{2,1} proxies of the
//    normals, Lloyd iterations), so chart borders run where the normal turns (high curvature).
// 2. Every chart must be a disk: connected, one boundary loop, Euler characteristic V - E + F = 1
//    (chart_is_disk). A chart that is not (a torus's band, a closed piece) is split in two by a
//    2-proxy VSA grown inside it from its two mutually farthest faces, and both halves are checked
//    again (with groups, each group goes to the side of its first triangle, and a side that falls
//    apart becomes one chart per connected piece).
// 3. Each disk is unwrapped (unwrap(), free boundary); a chart whose L2 stretch (eq. 5.5, per chart)
//    exceeds max_stretch, or whose map has a flipped or zero-area triangle, is split the same way
//    and both halves are unwrapped again. Splitting stops at max_charts (a warning).
// 4. Packing: every chart's map is scaled to its 3D area, turned to its smallest bounding box (16
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
  // Largest L2 stretch (eq. 5.5, Sander's normalisation, 1 = isometric) a chart may keep; charts
  // above it are split. > 1; infinity: no bound (charts are split only to make them disks).
  double max_stretch = 1.1;
  // Initial number of charts (VSA segments) before disks are enforced and stretch splits; >= 1,
  // at most the number of triangles. 0: automatic (8).
  int charts = 0;
  int max_charts = 2000;  // no stretch split beyond this many charts (>= 1)
  double margin = 0.005;  // gap between packed charts, as a fraction of the layout's side, in [0, 0.25)
  // Triangles that must stay in one chart (the triangles of one polygon): groups[f] >= 0 per
  // triangle, triangles of equal value are never cut apart. Empty: every triangle on its own.
  VecXi groups;
  UnwrapOptions unwrap;  // how each chart is unwrapped (unwrap.h defaults)
};

struct AutoUnwrapResult {
  MatX2d uv;            // (3m, 2) row 3f + k: UV of corner k of triangle f, packed in [0,1]^2
  VecXi chart;          // (m,) chart of each triangle, 0 .. n_charts-1
  MatX2i seams;         // (s, 2) vertex pairs of the edges between two charts (the cuts), v0 < v1
  VecXd chart_stretch;  // (n_charts,) L2 stretch of each chart's own map (eq. 5.5)
  UvMetrics metrics;    // of the packed map over all triangles (uv_metrics on the corner UVs)
  int n_charts = 0;
  int initial_charts = 0;   // charts of the VSA segmentation
  int topology_splits = 0;  // splits that made non-disk charts into disks
  int stretch_splits = 0;   // splits of charts above max_stretch (or with a failed map)
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
