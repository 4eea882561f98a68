// Fair surfaces by the discrete Willmore flow (thesis chapter 3): the elastica energy
// integral of H^2 dA is decreased by moving vertices along their normals with speed
// F = -Laplace_S(H) - 2H(H^2 - K) (eq. 3.5-3.7), plus a tangential drift that equalises the
// triangles (eq. 3.8, 3.10), optionally refining coarse-to-fine by linear 1-to-4 subdivision.
// Also: the bilaplacian and Laplacian-of-H comparison flows, region mode for hole restoration,
// and tangential regularisation alone (tau = 0).
#pragma once
#include <vector>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

enum class FairMethod {
  Willmore,      // F = -Laplace_S(H) - 2H(H^2 - K)           (eq. 3.5)
  Bilaplacian,   // P <- P - tau U0^2(P), uniform bi-umbrella   (section 3.2)
  LaplacianOfH,  // F = -Laplace_S(H)                          (eq. 3.12)
  // The edge-based (hinge) discrete Willmore energy sum_e 3 theta_e^2 |e|^2 / A_e (Grinspun et al.
  // 2003), minimised by Levenberg-Marquardt over the movable vertices from the linearised
  // minimiser U0^2 P = 0 (see fair.cpp, run_hinge). Region mode: it needs fixed vertices; a mesh
  // faired whole gets the Willmore flow. scheme, tangential, step_scale do not apply.
  Hinge,
};

enum class FairBoundary {
  Fixed,    // mesh-boundary vertices do not move
  Sliding,  // mesh-boundary vertices slide along the (original) boundary polyline
};

enum class FairScheme {
  // The thesis's forward-Euler step (3.8) with tau = A_min^2/150 (times step_scale).
  Explicit,
  // Same speed, preconditioned by a linearised implicit bi-Laplacian step:
  // u = tau (M + tau/2 L M^-1 L)^-1 M F N. It has the same fixed points as the explicit flow
  // (F = 0), is stable for any tau, and tau adapts (grows on success, shrinks when the energy
  // rises). For the bilaplacian flow it is backward Euler (I + tau U0^2) P' = P.
  SemiImplicit,
};

// Weights of the linearised minimiser the curvature flows and the hinge method start from (region
// mode, linear_start): B P = 0 at the movable vertices, the fixed rings as boundary data.
enum class FairStartWeights {
  // The uniform bi-umbrella U0^2 (thesis section 3.2): depends on the connectivity only.
  Uniform,
  // The cotangent bi-Laplacian L M^-1 L with the cotangent weights L (eq. 3.11) and mixed
  // (Voronoi) areas M of the *input* geometry (what CGAL's PMP::fair solves): a dented region keeps
  // the metric of the surface it was pushed from; a flattened one gets the projection's metric
  // (bench fair_repair: closer on some dents, farther on most flattened and noisy regions). The
  // uniform start is taken instead when a vertex within a ring of the movable ones has no mixed
  // area, the solve fails, or a movable component has no fixed vertex.
  Cotangent,
};

struct FairOptions {
  // Willmore. Hinge is closer to the original on bench fair_repair's damaged regions but not on hole
  // fills (refined or grid fills: Blender hole-workflow tests, bench/notes/fair.md).
  FairMethod method = FairMethod::Willmore;
  FairScheme scheme = FairScheme::SemiImplicit;
  FairBoundary boundary = FairBoundary::Fixed;
  // Vertices allowed to move (size n); empty: every vertex (mesh boundary per `boundary`).
  // Region mode: the fixed vertices next to the region keep positions and, through their
  // curvature, tangent planes (the two fixed rings of the thesis's hole restoration).
  std::vector<char> vertex_mask;
  // Faces refined by subdivision (size m); empty: faces touching a movable vertex (or every face
  // without a vertex mask). Edges between a refined and an unrefined face are never split, so
  // the faces outside the region keep their topology.
  std::vector<char> face_mask;
  // Coarse-to-fine levels (thesis fig. 3.5). After each split the new midpoints start at the
  // minimiser of the linearised energy with the old vertices held, when that lowers the energy.
  int subdivisions = 0;
  double tolerance = 1e-4;   // relative energy change per unit of flow time (see fair.cpp)
  int max_iterations = 300;  // per level (the explicit scheme's small steps need more: fair_defaults)
  // Semi-implicit curvature flows: a level also stops (converged) when the energy fell over the last
  // 8 accepted steps by less than min_progress times the smaller of its fall since the level's input
  // and the energy left (see fair.cpp, slow_progress); 0 = off (only the tolerance and the budget stop it).
  // Regions only (not to a part without fixed vertices), and not to a flow from the input whose
  // linear start was declined (the restart judges how far that flow gets). Bench fair_repair and fair_speed,
  // bench/notes/fair.md (issue 30).
  double min_progress = 0.01;
  double max_seconds = 0;   // wall-clock budget for the whole run; 0 = none
  bool tangential = true;   // add the tangential drift eps T (eq. 3.8)
  double step_scale = 1.0;  // multiplies the thesis's tau = A_min^2/150 (explicit scheme)
  // Willmore / Laplacian-of-H with fixed vertices: start from the minimiser of the linearised
  // energy (U0^2 P = 0, the bilaplacian flow's steady state, with the fixed rings as boundary
  // data) when that lowers the energy; see fair.cpp.
  bool linear_start = true;
  FairStartWeights start_weights = FairStartWeights::Uniform;  // of the linear start, see above
  // Before the flow, refine the region like Liepa's hole filling (see refine_region): a coarse
  // fill (Blender's Fill, a fan, an n-gon) gets triangles sized like the mesh around the hole.
  // The new vertices move; the region's border edges are never split. A fill that gets no new
  // vertex (already as fine as the mesh around it) is subdivided once when subdivisions is 0.
  bool refine = false;
  // Willmore and Laplacian of H: a connected component without fixed vertices (a closed object
  // faired whole) keeps its centroid and area. Both flows are scale-equivariant, so this only keeps
  // them from also moving and resizing the object.
  bool keep_size = true;
};

// Whether the flow changed the region (FairResult::stall). A flow that cannot lower the discrete
// energy from its start says so instead of returning the input as if it were done.
enum class FairStall {
  None,       // some level lowered the energy (bilaplacian: moved a vertex), or was restarted (see restarted)
  NoDescent,  // no vertex moved (by 1e-6 mean edge lengths): no step lowered the energy from the start
  NoChange,   // vertices moved, but no level lowered its energy by more than 10 x tolerance (relative)
};

// The defaults of a scheme: FairOptions{} (semi-implicit, 300 iterations per level) for SemiImplicit;
// for Explicit the thesis's small steps (tau = A_min^2/150) with 5000 iterations per level.
FairOptions fair_defaults(FairScheme scheme);

struct FairResult {
  MatX3d V;                           // original vertices first (same indices), then new ones
  MatX3i F;                           // unchanged when not subdivided
  VecXi face_origin;                  // input face each output face comes from
  std::vector<char> vertex_mask;      // vertices that were movable at the last level
  std::vector<double> energy;         // sum H^2 A (Hinge: hinge energy) per iteration; [0] = input
  std::vector<int> level_iterations;  // iterations spent on each level
  int iterations = 0;
  bool converged = false;     // the last level met the tolerance
  double lambda = 1.0;        // last H rescaling factor (thesis 3.1), 1 when H^2 >= K everywhere
  bool linear_start = false;  // the flow started from the linearised minimiser (iteration 1)
  // Some level's flow ended above the energy it started from (a mesh the flow cannot improve:
  // slivers, fan-triangulated caps); that level returned its lowest-energy state instead.
  bool energy_rose = false;
  // The flow from the input (linear start declined: it raised the energy) moved no vertex by a
  // quarter of the distance (largest vertex move) to the linearised minimiser, which lies more than
  // one mean edge length away: the flow stalled at a discrete minimum near the input (a flattened or dented region
  // whose crease along the fixed rim costs little of sum H^2 A at the mesh's resolution). The level was then run again
  // from the linearised minimiser (energy[] jumps up there), and its result kept even when its
  // energy ends above the input's. Only with linear_start (Willmore, Laplacian of H, fixed vertices).
  bool restarted = false;
  FairStall stall = FairStall::None;  // see FairStall; over independent parts: the worst part's
  // start_weights was Cotangent but the uniform start U0^2 P = 0 was used: a vertex within a ring of
  // the movable ones has no mixed area, the cotangent system's solve failed, or a movable component
  // has no fixed vertex (see FairStartWeights::Cotangent). Over independent parts: any part's.
  bool start_fallback = false;
};

/// Fairs V, F by the flow of `opt.method` (thesis eq. 3.5-3.12), the whole mesh or a region.
/// A face mask alone selects its faces' vertices except the region's border. Parts of a region
/// that do not interact (their two-ring neighbourhoods are disjoint) are faired one after the
/// other, each with its own step control; the result sums their energies (each held at its last
/// value) and reports the most iterations, the smallest lambda, converged only if all did.
/// Pre: a valid triangle mesh (validate.h, kSurface) when anything moves; masks of size n / m.
/// Throws MeshError (bad input or options, nothing to fair), CancelledError (progress false).
FairResult fair(const MatX3d& V, const MatX3i& F, const FairOptions& opt, const ProgressFn& progress = {});

struct RegularizeOptions {
  int iterations = 100;
  std::vector<char> vertex_mask;  // movable vertices; empty = all
  FairBoundary boundary = FairBoundary::Fixed;
  double step_scale = 1.0;  // multiplies the thesis's eps = 12 A_min (A_min within two rings of each vertex)
  // Project moved vertices back onto the input surface after each step (the drift alone leaves
  // a curved surface by O(step^2 * curvature) per step, which accumulates).
  bool project = true;
};

// Tangential drift alone (eq. 3.8 with tau = 0, fig. 3.3-3.4): equalises triangle sizes and
// shapes, moving vertices in their tangent planes. Returns the new positions.
MatX3d regularize(const MatX3d& V, const MatX3i& F, const RegularizeOptions& opt, const ProgressFn& progress = {});

// Discrete Willmore energy sum_i H_i^2 A_i (mixed areas): 4 pi on a round sphere.
double willmore_energy(const MatX3d& V, const MatX3i& F);

struct RegionSubdivision {
  MatX3d V;
  MatX3i F;
  VecXi face_origin;
  std::vector<char> face_mask;      // faces of the refined region
  std::vector<int> edge_a, edge_b;  // parents of each new vertex n + i
};

// Linear subdivision of the faces in `face_mask` only: edges whose faces are all in the region
// get their midpoint; a face with 3/2/1/0 split edges becomes 4/3/2/1 triangles. Border edges
// are not split, so faces outside the region are unchanged (same rows, same indices).
RegionSubdivision subdivide_region(const MatX3d& V, const MatX3i& F, const std::vector<char>& face_mask);

// Liepa-style refinement of a hole fill (P. Liepa, "Filling holes in meshes", SGP 2003, sec. 3.2-3.3):
// a region that is a fill without inner vertices (one boundary loop through all its vertices, up to
// 600 of them) is first re-triangulated by Liepa's minimum-weight triangulation of the loop (smallest
// largest dihedral angle, with the faces around the hole included, then smallest area), so the
// result does not depend on how the hole was filled (a fan, an n-gon's triangulation); then each
// vertex gets a target edge length sigma (the mean length of its edges outside the region;
// the mean over the region's border for vertices inside it); a region triangle whose centroid c
// has density * |c - v| > max(sigma(c), sigma(v)) for its three corners v is split 1-to-3 at c
// (sigma(c) = mean of the corners'), and region-interior edges are flipped to the Delaunay
// (opposite angles sum <= pi) configuration after each round, until nothing splits; when it split, a
// last pass flips edges that bring valences closer to 6 without creating angles under 15 degrees (the
// flow's linear start depends on the connectivity only), and new vertices left with valence 3
// are removed (their three triangles merged: the uniform umbrella of a valence-3 vertex put it
// on a spike in the linear start). Border edges
// of the region are never split or flipped, so faces outside keep their topology. New vertices
// follow the input's (n + i); rows of the input's faces keep their index (a region row may hold
// another region triangle after flips and merges), extra faces follow with face_origin a region
// face. edge_a/edge_b stay empty.
RegionSubdivision refine_region(const MatX3d& V, const MatX3i& F, const std::vector<char>& face_mask,
                                double density = 1.4142135623730951);

}  // namespace dgmesh
