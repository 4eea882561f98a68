// Skeleton-driven, thickness-preserving mesh deformation (thesis chapter 6, after Yoshizawa,
// Belyaev and Seidel [YBS03, YBS06]).
//
// A closed mesh M is written as M = S + d N (eq. 6.1): S is a skeletal mesh (one Voronoi pole per
// vertex, the connectivity of M, thesis 6.1) and d(i) = |x_i - s_i| the medial-ball radius (eq.
// 6.7). Posing the bones deforms S by skeletal subspace deformation (eq. 6.2); the deformed mesh is
// rebuilt around the deformed skeleton, either variationally (6.5: per-triangle frames, eq. 6.8,
// stitched by the graph Laplacian L0 of eq. 6.9-6.12, factorised once) followed by the
// shape-preserving self-intersection fairing eq. 6.15, or by the basic homotopy method of 6.3
// (eq. 6.3-6.6) for comparison. A dense mesh goes through the multiresolution layer (multires.h):
// the skeletal machinery runs on its decimated control mesh.
#pragma once
#include <array>
#include <memory>
#include <vector>

#include "dgmesh/fold_guard.h"
#include "dgmesh/mesh.h"
#include "dgmesh/multires.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

using Mat4 = Eigen::Matrix4d;

struct SkeletonOptions {
  // Bilaplacian tangential flow applied to a copy of the mesh before the Voronoi poles are taken
  // (thesis 6.1 "Pre-Smoothing"); the mesh itself is not changed.
  int presmooth_iterations = 10;
  double presmooth_step = 0.2;  // of the uniform bi-umbrella (stable below 0.5)
  // Post-smoothing of the skeletal mesh (thesis 6.1 end): bi-umbrella steps applied at skeletal
  // vertices whose smoothing vector points against the mesh normal, and always at spikes (radius
  // above spike_factor times the median of the ring's radii) and at inverted vertices (on the
  // outer side of the surface).
  int postsmooth_iterations = 20;
  double postsmooth_step = 0.2;
  double spike_factor = 2.5;
  // Inner pole candidates: Voronoi vertices of the cell that lie within this angle (radians) of
  // the inward normal.
  double max_pole_angle = 1.2;
};

struct SkeletalMesh {
  MatX3d S;                // skeletal vertices, one per mesh vertex; faces are the mesh's
  VecXd radii;             // d(i) = |x_i - s_i| (eq. 6.7)
  int n_fallback = 0;      // vertices without an inner Voronoi pole (placed from their ring)
  int n_postsmoothed = 0;  // vertices moved by the post-smoothing
};

// Skeletal mesh of a closed, consistently oriented manifold mesh (validated by the caller).
SkeletalMesh skeletal_mesh(const Mesh& mesh, const SkeletonOptions& opt = {});

// Normalised Gaussian weights of the distance from each point to the bone segments
// (head, tail): w_j ~ exp(-(dist_j^2 - min_k dist_k^2) / (2 sigma^2)). Returns n x B.
Eigen::MatrixXd gaussian_bone_weights(const MatX3d& P, const MatX3d& heads, const MatX3d& tails, double sigma);

// (The rig follows SSD with a bone-clearance step: each posed skeletal vertex is pushed back out to
// its rest distance from the posed segments of the bones it has weight on; see
// SkeletalRig::Impl::clear_bones.)
// Skeletal subspace deformation (eq. 6.2): z -> sum_j w_j (pose_j rest_j^-1) z. W is n x B with
// rows summing to 1. If `linear` is given it receives, row-major (n x 9), the rotation of each
// point's frame: the bone rotations blended as normalised quaternions. With `dual_quaternion`
// (and rigid bone motions; otherwise the linear blend is used) the points are moved by the blended
// dual quaternion instead (thesis 6.2 leaves the space deformation of the skeletal mesh open).
MatX3d skeletal_subspace_deform(const MatX3d& P, const Eigen::MatrixXd& W, const std::vector<Mat4>& rest,
                                const std::vector<Mat4>& pose,
                                Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>* linear = nullptr,
                                bool dual_quaternion = false);

// Signed distance to the union of balls (s_j, r_j) (eq. 6.13) for each point, through a kd-tree;
// exact (every ball that can matter is visited). `nearest` (optional) receives the minimising ball.
VecXd union_of_balls_distance(const MatX3d& X, const MatX3d& centers, const VecXd& radii,
                              std::vector<int>* nearest = nullptr);

// Signed distance E_T(x) from x to the convex hull of the three balls (c[k], r[k]) (thesis 6.3.1,
// the E_T of the force of eq. 6.5): the hull is the union of the balls centred in the triangle
// c0 c1 c2 with barycentrically interpolated radii, so E_T(x) = min over barycentric l of
// |x - c(l)| - r(l), a convex problem solved exactly (the interior stationary point, else the
// closest of the three edges' cone-spheres). Outside the hull it is the Euclidean distance to it;
// inside, minus the depth in the deepest interpolated ball. Radii must be >= 0. `gradient`
// (optional) receives grad E_T(x): the unit vector from the minimising centre c(l) to x (the
// triangle's normal on x's side when x is that centre).
double ball_hull_distance(const Vec3& x, const std::array<Vec3, 3>& c, const Vec3& r, Vec3* gradient = nullptr);

enum class SkeletalMethod {
  Variational,  // 6.5: eq. 6.8-6.12 and the fairing eq. 6.15
  Basic,        // 6.3: homotopy eq. 6.3-6.4, folds/protrusions eq. 6.5, self-intersections eq. 6.6
};

struct SkeletalRigOptions {
  SkeletonOptions skeleton;
  // The multiresolution layer is used when the mesh has more faces than this; the skeletal
  // machinery then runs on a control mesh of about this many faces.
  int control_faces = 5000;
  int multires_level = 2;
  int multires_fit_iterations = 1;
  // Gaussian weights when none are given: sigma, 0 = a fifth of the median medial radius.
  double gaussian_sigma = 0;
  // Frames of degenerate skeletal triangles (a region collapsed to a curve or a point, thesis 6.5
  // discussion): the triangle's rotation is fitted to its edges plus this weight (relative to the
  // mean squared skeletal edge length) times the SSD-blended bone rotation, which fixes the
  // directions the edges do not determine (the twist about a curve, all of them at a point).
  double frame_regularization = 0.05;
};

struct SkeletalDeformOptions {
  SkeletalMethod method = SkeletalMethod::Variational;
  int fairing_steps = 2;      // steps of eq. 6.15 (variational) or of eq. 6.6 (basic)
  double fairing_step = 1.5;  // epsilon of eq. 6.15 (over-relaxed: L0^-1 damps the update)
  // After the fairing steps (variational, fairing_steps > 0): one explicit step u <- u - w f grad f
  // of the flow eq. 6.14 without the L0^-1 smoothing, one-sided: each vertex nearer the union of
  // balls than at rest moves by w times that shortfall (w = 1: out onto its rest distance); one
  // farther than at rest stays. The semi-implicit steps spread a local thickness loss (a sharp
  // twist) over the whole shape and converge slowly there; 0 = off. Flesh that a bend squeezes out
  // of the union (the crease) bulges instead of being pulled back into the union's concave corner,
  // where neighbours heading for different balls fold (capsule bent 90 degrees through the layer:
  // 604 self-intersecting pairs with the pull, 105 without; DQS 95; bench/notes/skeletal.md).
  // Through the multiresolution layer the dense vertices get the same step against the control
  // mesh's medial balls (the layer's limit surface thins where a pose shears the control mesh).
  double projection = 1.0;
  // Passes of that explicit step, at most: a vertex pushed out of one ball may land in a
  // neighbour's. The passes after the first visit only the vertices the previous one moved, and
  // stop once a pass moves none.
  int projection_passes = 8;
  // Passes of the dense mesh's explicit step (multiresolution layer). A pass after the first visits
  // only the vertices whose minimising ball changed or whose move may have taken them into another
  // candidate ball, so three cost little more than one.
  int dense_projection_passes = 3;
  // Skeletal mesh editing (6.2) by dual quaternion blending of the bone motions (rigid per skeletal
  // vertex) instead of the linear blend of eq. 6.2 (false), which pulls skeletal vertices that lie
  // off a bone's axis towards it under a twist (a limb whose medial surface is a sheet collapses
  // onto the bone and the mesh rebuilt on it tears open). See bench/notes/skeletal.md.
  bool dual_quaternion = true;
  // Skeletal mesh integration (issue 33's crease): the blend above moves each skeletal vertex about
  // the joint by its blended motion, so across a joint's blend the vertices behind the joint swing
  // backwards and the posed axis turns by about twice the bend inside the blend (a linear blend over
  // [-r, r] bent 75 degrees: 149 degrees, with kinks at the blend's ends). The union of balls then has
  // a concave corner in the crease, and the thickness steps fold the surface into it. With this on
  // (the default), the posed skeletal mesh is rebuilt after the bone clearance as the surface is in
  // eq. 6.11: least squares over its edges, each edge's target the rest vector turned by its two
  // ends' mean blended rotation plus a beam's stretch (its offset from the stick skeleton turned by
  // the difference of the two rotations: plane sections stay plane, so a bend's outer side and a
  // twisted sheet stretch as they must); held where one bone moves a vertex alone and anchored
  // softly to the blend's position where a bone dominates (largest weight 0.9-0.99); coincident
  // skeletal vertices move as one. The axis turns as the weights do (by the bend over the blend), and
  // the parts one bone moves stay where they are put. Factorised at bind; a pose costs one solve.
  // Rest pose and rigid motions: no move; nor where follow_twist acts (it carries each skeletal
  // vertex back by its own twist, which the integration mixes). The axis cuts the joint's corner: the
  // skeletal vertices keep at least half their rest distance from their bones (not all of it), and
  // the surface bone clearance pushes more of a bend's outer side back out. Measurements:
  // bench/notes/skeletal.md, sessions 32-33.
  bool integrate_skeleton = true;
  // Joint fillets (issue 33's crease), the fillet radius sought over the limb's radius, 0 = off: at
  // each bent joint (a bone whose head starts at its parent's tail) the posed skeletal mesh follows an
  // arc tangent to both bones instead of the blend's swing about the joint, and the reconstructed
  // surface is moved to the same map of the rest surface before the thickness steps (joint_fillet.h:
  // the band of the weight blend, widened towards this radius; each cross-section turned rigidly,
  // the band's axis shortened to the arc). Replaces the integration on poses with a bent joint. A
  // vertex follows by its share of weight on the joint's two bones (fully from 3/4), and turns by
  // its share of the child's twist, from the ring weights with ring_twist on (a cross-section turns
  // as one; the weights, where they vary around the limb, fold a bent and twisted joint). With the
  // untangling on (untangle_iterations > 0) it fades out where its radius falls below 1.2 limb radii
  // and is blended from the integrated skeleton, from which the untangling's slide clears a tight
  // bend. Rest pose, rigid motions and pure twists: no change. Measurements:
  // bench/notes/skeletal.md, session 35.
  double joint_fillet = 2.0;
  // Twist by rings (issue 33): the blend twists a skeletal vertex about a bone's axis by an angle
  // that follows its weight, and where the weights vary around the limb (automatic weights at a
  // knee) a large twist folds the skeletal mesh and the surface rebuilt on it, as it folds dual
  // quaternion skinning (ring_weights.h). With this on (the default), the part of a pose that
  // twist_free_pose drops (the twists that dominate their bone's swing; follow_twist's) is blended
  // with the weights smoothed around each limb (SkeletalRig::ring_weights), so each cross-section
  // turns as one; the rest of the pose keeps the weights. Poses without such a twist: no change.
  // Measurements: bench/notes/skeletal.md, session 34.
  bool ring_twist = true;
  // Surface bone clearance (variational method, fairing_steps > 0), in [0, 1]: after the thickness
  // steps, each control vertex is pushed radially out until its distance to the union of the posed
  // segments of the bones it has weight on and of their parents is at least this fraction of its
  // rest distance to them (the surface counterpart of the skeletal vertices' clearance; no push in
  // the rest pose or under rigid motions). Through the multiresolution layer the dense vertices get
  // the same push, against the bones of their base face's control vertices. 1 keeps every rest
  // distance but costs thickness under twists; 0 = off. See bench/notes/skeletal.md.
  double bone_clearance = 0.95;
  // Joint contact (variational method, fairing_steps > 0; issue 33's crease), kappa >= 1 or 0 =
  // off: at each joint whose bend a pose changes (a bone whose head starts at its parent's tail),
  // the bisector plane of the two posed bones is the surface along which the two limbs' flesh
  // meets. Each vertex near the joint (rest distance to it below the shorter bone's length, weight
  // on the two bones above 1/2) belongs to the limb on its rest side of the rest bisector plane.
  // Its line parallel to its own posed bone crosses the posed plane at the distance t_c from the
  // joint along that bone; where t_c > 0 the vertex's axial distance t in [0, kappa t_c] is mapped
  // linearly onto [t_c, kappa t_c] (a slide along its own bone, away from the joint): no vertex of
  // one limb stays on the other limb's side, the distance to the own bone's line is kept, and
  // the map is monotone along each line (neighbours with different t_c can still turn a face).
  // Applied after the thickness steps and the surface bone clearance and before the fold guard,
  // which smooths the faces the slide turns with the others; to the control vertices and, through
  // the multiresolution layer, to the dense ones. No move in the rest pose, under rigid motions or
  // pure twists. Not a thickness term. Off by default: with it a capsule's bends are at or below
  // dual quaternion skinning's pairs on both paths (none limb against limb) and the camel knee's
  // at 135 degrees too, but through the multiresolution layer it adds pairs on the armadillo's knee
  // at 90 degrees (see bench/notes/skeletal.md, session 27); 3 is the measured setting.
  double contact_slide = 0.0;
  // Untangling (variational method, fairing_steps > 0; issue 33), iterations, 0 = off: the
  // thesis's smoothing term of eq. 6.15 applied where the surface folds. First, when contact_slide
  // is off, the joint contact's slide (kappa 8, over the vertices within 1.5 times the shorter bone
  // of a joint) is tried and kept if it lowers the count of self-intersecting pairs and the root
  // mean square thickness error (eq. 6.13) of the vertices it moved grows by at most one median
  // medial radius (flesh far from its bone slides off its medial distance): in a tight bend
  // the limbs' flesh piles into the concave corner, which the smoothing cannot clear without sinking
  // it onto the other limb's bone. Then each iteration finds the
  // self-intersecting triangle pairs (self_intersection.h), smooths their vertices and
  // untangle_rings rings around them (three Jacobi steps of the uniform umbrella operator, weight
  // 1/2) and pushes them back out to at least max(0.9, bone_clearance) of their rest distance to
  // the bones they follow, their parents and their children (a vertex the push cannot clear keeps
  // its position). An iteration that does not lower the count is undone and the next takes one ring
  // more (at most 3 more). Pairs that cross at rest are left alone. Applied last, to the control
  // mesh and, through the multiresolution layer, to the dense one (its faces with a vertex not moved
  // rigidly by one bone; not for data saved without the dense faces). Off by default: each
  // iteration costs a self-intersection search (see bench/notes/skeletal.md for what it measured).
  // rings 4: capsule of bench skeletal_limb bent 90 degrees, 5 pairs left (2 rings: 49; DQS 46).
  int untangle_iterations = 0;
  int untangle_rings = 4;
  // Fold guard (variational method, fairing_steps > 0; issue 33), iterations, 0 = off: the
  // thickness steps (eq. 6.15, the explicit projection, the surface bone clearance) move each
  // vertex on its own, and where neighbours head for different balls (the concave corner of a bent
  // joint's union of balls) faces turn over and the surface folds through itself. After them, every
  // face whose normal points against its normal in the bare reconstruction (eq. 6.11; through the
  // multiresolution layer, the dense mesh's limit surface before its own step) has its vertices'
  // and one ring's displacement averaged with their one-ring's (fold_guard.h), each smoothed vertex
  // pushed back out to bone_clearance of its rest distance to the untangling's bones (its own,
  // their parents and children; a vertex the push cannot clear keeps its position), until no face
  // is turned or these iterations (or fold_guard.h's work bound) run out. A face whose reference
  // normal itself points against its rest normal turned by its blended bone rotation (the
  // reference folds there; the steps unfold it) is left alone. With contact_slide acting on the
  // whole mesh (no multiresolution layer, no skeleton edit), a second pass takes the dual
  // quaternion skinning of the rest mesh as the reference, every face trusted. No search: the cost
  // follows the turned faces. Rest pose, rigid motions and poses that turn no face: no move.
  // Measurements: bench/notes/skeletal.md.
  int fold_guard = 50;
  // Thickness that follows the twist (variational method, dual quaternion skeleton; issue 33), off by
  // default: each bone's motion relative to its parent is split into a swing and a twist about the
  // bone's own rest axis; dropping the twists gives the twist-free pose, and each skeletal vertex its
  // own twist, the rigid motion M_i = T_i U_i^-1 from its blend U_i of the twist-free pose to its
  // blend T_i of the pose. The thickness of eq. 6.13 is then measured in the twist-free pose (vertex
  // i at M_i^-1 x_i against the balls (M_j^-1 s^d_j, r_j), its step turned back by M_i), and the
  // frames of eq. 6.8 are fitted there and turned by the triangle's twist (its corners' mean), so the
  // balls of a twisted medial sheet off the bone's axis stay where the twisted flesh is. Through the
  // multiresolution layer each dense vertex of the limit surface is carried to the twist-free pose by
  // its base face's corners' twist, measured there and turned back. Only a twist that dominates its
  // bone's swing is dropped: all of it where the swing is at most half the twist, none where it is at
  // least the twist. A pose without such a twist (every dropped twist below 1e-6 rad) gives exactly
  // the result without the option. A twisted waist's flesh is no longer pushed out onto the balls
  // the twist turns into it (bench skeletal_blender's armadillo twisted 180 degrees at the waist: 2500
  // crossing pairs and volume 1.125 without, 0 and 0.998 with; DQS 0). Off by default: measured in
  // the pose against the posed skeletal mesh, a twisted leg's thickness error grows from 0.05 to 0.5
  // of DQS's (bench skeletal_limb's camel and armadillo legs twisted 180 degrees; issue 8's target is
  // 0.2), since each ball turns with its own surface vertex's twist, not with the flesh around it.
  // Measurements: bench/notes/skeletal.md, sessions 25 and 36.
  bool follow_twist = false;
  int homotopy_steps = 3;    // L of eq. 6.3
  int fold_iterations = 10;  // steps of eq. 6.5 (basic)
};

// The arrays that define a binding (save/load).
struct SkeletalRigData {
  MatX3d control_V;  // rest control mesh (the mesh itself when no multires layer)
  MatX3i control_F;
  MatX3d S;                 // skeletal vertices
  Eigen::MatrixXd weights;  // n_control x B, rows sum to 1
  std::vector<Mat4> bones_rest;
  // The stick skeleton (B x 3 each): the segments the bone clearances, the joint contact and the
  // twist axes measure against. Empty (data saved before it was kept): from the rest frames, head =
  // translation, direction = Y axis (Blender's convention).
  MatX3d bone_heads, bone_tails;
  bool has_multires = false;
  MultiresData multires;
  MatX3i dense_F;  // the dense mesh's faces (untangling through the layer); may be empty
  double frame_regularization = 0.05;
};

class SkeletalRig {
 public:
  // Binds the mesh (V, F) to the bones (4x4 rest matrices in the mesh's object space).
  // `weights` is n x B (per vertex of V) or empty; when empty, Gaussian weights of the distance of
  // the skeletal vertices to the bone segments (bone_heads, bone_tails, B x 3) are used.
  // bone_heads / bone_tails (B x 3, or both empty) are the stick skeleton: the segments the bone
  // clearances, the joint contact and the twist axes measure against. Only the motion
  // (pose * rest^-1) comes from the frames. Without them the segments come from the frames (head =
  // translation, direction = Y axis, Blender's convention), which is wrong for frames that do not
  // follow it (e.g. identity rest frames).
  // The mesh must be closed and manifold; throws MeshError (nothing bound) otherwise, and when
  // some vertex has no weight in any bone.
  static SkeletalRig bind(const MatX3d& V, const MatX3i& F, const std::vector<Mat4>& bones_rest,
                          const Eigen::MatrixXd& weights, const MatX3d& bone_heads, const MatX3d& bone_tails,
                          const SkeletalRigOptions& opt = {}, const ProgressFn& progress = {});
  static SkeletalRig from_data(const SkeletalRigData& data);
  SkeletalRigData data() const;

  // Deformed dense positions for the given pose matrices (B of them, same space as the rest ones).
  //
  // `skeleton` (optional; free-form skeleton editing, thesis 6.2: any space deformation of the
  // skeletal mesh): the skeletal vertices (n_control x 3, rest space) moved by any deformation
  // (a lattice, hooks, sculpting the skeletal mesh). The edit comes first and the bones pose the
  // edited skeleton (each skeletal vertex's offset from its rest position turns with its blended
  // bone frame), so the rest pose gives the edit alone. The surface is rebuilt around it with
  // its thickness (medial radii) kept. The bone clearance steps leave the vertices whose skeletal
  // vertex the edit moved (and dense vertices on their faces) alone: an edit may bring flesh
  // closer to a bone. Throws MeshError for a wrong shape or a non-finite value.
  MatX3d deform(const std::vector<Mat4>& bones_pose, const SkeletalDeformOptions& opt = {},
                const MatX3d* skeleton = nullptr) const;
  // The same into a caller-owned (n_vertices x 3) array (the live update reuses one buffer), in
  // double or single precision (computed in double; single precision suits Blender's foreach_set;
  // through the multiresolution layer the dense thickness step reads the float32 values back).
  void deform(const std::vector<Mat4>& bones_pose, const SkeletalDeformOptions& opt, Eigen::Ref<MatX3d> out,
              const MatX3d* skeleton = nullptr) const;
  void deform(const std::vector<Mat4>& bones_pose, const SkeletalDeformOptions& opt, Eigen::Ref<MatX3f> out,
              const MatX3d* skeleton = nullptr) const;
  // The same on the control mesh only, also returning the deformed skeletal vertices.
  MatX3d deform_control(const std::vector<Mat4>& bones_pose, const SkeletalDeformOptions& opt,
                        MatX3d* skeleton_pose = nullptr, const MatX3d* skeleton = nullptr) const;

  int n_vertices() const;  // dense
  int n_control() const;
  int n_bones() const;
  bool has_multires() const;
  const MatX3d& control_vertices() const;
  const MatX3i& control_faces() const;
  const MatX3d& skeleton_vertices() const;
  const VecXd& radii() const;
  const Eigen::MatrixXd& weights() const;  // per control vertex
  // The weights smoothed around the limbs that twists are blended with (ring_weights.h with its
  // defaults, radius = the medial radii; SkeletalDeformOptions::ring_twist).
  const Eigen::MatrixXd& ring_weights() const;
  const std::vector<Mat4>& bones_rest() const;
  // Skeletal vertices posed as deform() poses them by default (SSD eq. 6.2, the bone clearance, the
  // skeletal mesh integration).
  MatX3d skeleton_pose(const std::vector<Mat4>& bones_pose) const;

  struct Impl;

 private:
  explicit SkeletalRig(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

}  // namespace dgmesh
