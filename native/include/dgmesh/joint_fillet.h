// A bent joint's fillet (issue 33: the crease of a bent elbow or knee).
//
// Blending the two bones' motions (thesis eq. 6.2, or dual quaternions) turns each point about the
// joint by an angle that follows its weight, so the limb's axis swings through the joint and the
// inner side of a bend piles into a point: a tube of radius r around an axis bent with a radius of
// curvature below r crosses itself on the inner side, and a thickness-keeping surface rebuilt around
// it must too (a capsule of radius 0.5 bent 90 degrees with Blender's automatic weights: its posed
// axis turns with a smallest radius of 0.15; bench/notes/skeletal.md, session 34).
//
// The fillet instead bends the axis along a circular arc tangent to both bones: with e the mean rest
// axis at the joint J, n the axis of the child bone's swing by delta (its bend relative to the
// parent), w = n x e (the bend's inner side) and t = (y - J) . e a point's axial coordinate, the band
// |t| < L is mapped by the rigid motion of its cross-section at u = (t + L) / (2 L):
//   F(y) = J + R(n, u delta) T(wt tau) (y - J) + a(t) - R(n, u delta) t e,
//   a(t) = (R_f sin(u delta) - L) e + R_f (1 - cos(u delta)) w,   R_f = L / tan(delta / 2),
// T(wt tau) the child's twist about its own axis b0 by the point's share wt of it. a(t) is the arc of
// radius R_f from J - L e to J + L R(n, delta) e (the chord of a fillet tangent to both axes at
// distance L from the joint), so the map is the identity for t <= -L and the child's rigid motion
// relative to the parent for t >= L (and wt = 1); the axial length inside the band shrinks to the
// arc's, R_f delta / (2 L) = (delta / 2) / tan(delta / 2) of it (0.79 at 90 degrees). A cross-section
// of the band turns rigidly, so the tube around the arc does not fold while R_f exceeds the limb's
// radius on the inner side. The parent's motion P is applied last.
//
// The band's half-length L: at least the extent of the joint's weight blend (the artist's choice of
// where the limb bends), stretched to radius_scale times the limb's radius r in fillet radius, but
// not beyond reach times the shorter bone nor so far that the arc passes more than r inside the
// joint's corner (R_f (1 / cos(delta / 2) - 1) <= r: the outer side would be carried past the joint),
// i.e. L_wide = max(L_w, min(L_k, reach l_min, L_o)), L_k = k r tan(delta / 2) and
// L_o = r tan(delta / 2) / (1 / cos(delta / 2) - 1). A weight blend wider than L_o carries the outer
// side past the joint all the same, where the bone clearance pushes it back out and folds it (a
// capsule of radius 0.5 with Gaussian weights of sigma 1 bent 90 degrees: 64 crossing pairs, DQS 0),
// so L_o caps the blend's extent too while it allows the sought radius (L_o >= L_k: bends up to about
// 96 degrees for k = 2), L_kept = min(L_wide, max(L_o, L_k)). In tighter bends no band keeps both
// sides; there the wide band folds less, and the cap is given up as L_o falls to two thirds of L_k
// (about 110 degrees): L = L_kept + smoothstep(3 (1 - L_o / L_k)) (L_wide - L_kept) (bench/notes/
// skeletal.md, session 37). Over 120 degrees R_f < r and the inner side folds as the limbs meet.
// The fillet is blended in over the first kOnset of the bend, so a pose path leaving
// the straight joint (or a pure twist) is continuous.
#pragma once
#include <optional>

#include "dgmesh/types.h"

namespace dgmesh {

struct JointFilletOptions {
  double radius_scale = 2.0;  // k: the fillet radius sought, over the limb's radius (> 0)
  double reach = 0.5;         // the band's half-length at most this times the shorter bone
  // > 0: the fillet's weight also fades out (smoothstep) as its radius falls from this many limb
  // radii to two thirds of it (in tight bends the arc cannot clear the inner side; 0: no fade).
  double fade = 0.0;
};

// One joint in one pose. `map` takes a rest point, its axial coordinate t (of the point whose
// cross-section carries it, see t_of) and its share wt in [0, 1] of the child's twist, and returns
// its position relative to the parent's motion (apply parent_motion after); R receives the rotation.
struct JointFillet {
  Vec3 joint, axis, inner, bend_axis, child_axis;
  Eigen::Matrix3d relative, swing;  // the child's rotation relative to the parent, and its swing part
  double bend = 0, twist = 0, half_length = 0, radius = 0;
  double weight = 0;  // the fillet's blend weight in [0, 1] (0 at a straight joint, 1 past the onset)
  double t_of(const Vec3& rest_point) const { return (rest_point - joint).dot(axis); }
  Vec3 map(const Vec3& rest_point, double t, double wt, Eigen::Matrix3d& R) const;
};

// The fillet of the joint between a parent bone (rest direction parent_dir, ending at `joint`) and
// its child (rest direction child_dir) when the child moves by `relative` (4 x 4: the child's motion
// composed with the inverse of the parent's; only its rotation is used); blend_extent L_w and
// limb_radius r at rest (see above), min_bone_length the shorter bone. None when the joint is not
// bent (the child's swing is below 1e-4 rad), folded back on itself (within 1e-3 rad of 180 degrees)
// or the inputs are degenerate (zero directions or radius). Throws MeshError on non-finite input or
// options out of range.
std::optional<JointFillet> joint_fillet(const Eigen::Matrix4d& relative, const Vec3& joint, const Vec3& parent_dir,
                                        const Vec3& child_dir, double blend_extent, double limb_radius,
                                        double min_bone_length, const JointFilletOptions& opt = {});

}  // namespace dgmesh
