// Quadric-error-metric edge-collapse decimation (Garland-Heckbert 1997) with per-face weights
// (thesis 4.8: w = 1/F(d) keeps density near crest lines). Manifold- and boundary-preserving: a
// collapse is taken only if it passes the link condition, keeps every vertex's fan valid, flips no
// face and (optionally) creates no sliver. Priority queue with lazy invalidation by vertex stamps.
#pragma once
#include <limits>
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

struct DecimateOptions {
  int target_faces = 0;  // stop when at most this many faces are left
  // Stop earlier when the cheapest collapse costs more than this (quadric error, length^2 per
  // unit face weight when area weighting is on it is length^4).
  double max_error = std::numeric_limits<double>::infinity();
  // Weight of each input face's quadric (empty: all 1). Thesis 4.8 uses 1 / F(d).
  VecXd face_weights;
  bool area_weighted = true;  // face quadrics scaled by the face area (GH97 sec. 6)
  // true: boundary vertices never move and are never removed, so the boundary stays exact.
  // false: boundary edges may collapse along the boundary, held by perpendicular constraint planes.
  bool preserve_boundary = true;
  double boundary_weight = 100.0;  // constraint-plane weight (relative) when not preserving
  // Per input vertex (empty: none): locked vertices never move and are never removed, e.g. the
  // vertices on UV seams or material borders, so those stay exact and attributes stay consistent.
  std::vector<char> locked;
  // Per input vertex (empty: none): bit k set when the vertex lies on plane k (a Mirror modifier's
  // planes). No collapse makes a face with its three corners on one plane: such a face lies in the
  // plane, where the mirrored half puts its twin, and the mirrored mesh is no longer manifold.
  std::vector<char> planes;
  // A collapse is rejected if a face normal turns by more than this angle (radians; < pi/2 also
  // rules out flips) ...
  double max_normal_angle = 1.3;
  // ... or if the worst triangle around it afterwards has a quality 4 sqrt(3) A / (l0^2 + l1^2 + l2^2)
  // (1 for equilateral) below min_quality and below the worst one's before the collapse.
  double min_quality = 0.0;
  // true: multiple-choice passes (cost every edge in parallel, take the cheapest independent ones
  // in order); false: one global priority queue, the exact greedy order of GH97. Same guards.
  bool batched = true;
};

struct DecimateResult {
  MatX3d V;
  MatX3i F;
  // For each input vertex, the output vertex it was merged into (itself if it survived); -1 for
  // loose input vertices (they are dropped).
  std::vector<int> vertex_map;
  // For each output face, the input face it is (with some corners moved to merged vertices); for
  // each output vertex, the input vertex that survived as it. Attributes (UVs, materials) follow.
  std::vector<int> face_map, source_vertex;
  int collapses = 0;
};

// Decimates a validated mesh (make_mesh) to opt.target_faces faces or as close as the guards allow.
DecimateResult decimate(const Mesh& mesh, const DecimateOptions& opt, const ProgressFn& progress = {});

}  // namespace dgmesh
