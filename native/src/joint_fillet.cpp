#include "dgmesh/joint_fillet.h"

#include <algorithm>
#include <cmath>

#include "dgmesh/detail/math.h"
#include "dgmesh/detail/skeletal_util.h"
#include "dgmesh/errors.h"

namespace dgmesh {

namespace {
// The bend over which the fillet is blended in (10 degrees).
constexpr double kOnset = 0.17453292519943295;
}  // namespace

Vec3 JointFillet::map(const Vec3& y, double t, double wt, Eigen::Matrix3d& R) const {
  const double u = std::clamp((t + half_length) / (2 * half_length), 0.0, 1.0), phi = u * bend;
  Vec3 arc;
  if (t <= -half_length)
    arc = t * axis;
  else if (t >= half_length)
    arc = t * (swing * axis);
  else
    arc = (radius * std::sin(phi) - half_length) * axis + radius * (1 - std::cos(phi)) * inner;
  const Eigen::Matrix3d Rphi = Eigen::AngleAxisd(phi, bend_axis).toRotationMatrix();
  R = Rphi * Eigen::AngleAxisd(wt * twist, child_axis).toRotationMatrix();
  return joint + R * (y - joint) + arc - Rphi * (t * axis);
}

std::optional<JointFillet> joint_fillet(const Eigen::Matrix4d& relative, const Vec3& joint, const Vec3& parent_dir,
                                        const Vec3& child_dir, double blend_extent, double limb_radius,
                                        double min_bone_length, const JointFilletOptions& opt) {
  if (!relative.allFinite() || !joint.allFinite() || !parent_dir.allFinite() || !child_dir.allFinite() ||
      !std::isfinite(blend_extent) || !std::isfinite(limb_radius) || !std::isfinite(min_bone_length))
    throw MeshError("joint_fillet: inputs must be finite");
  if (!(opt.radius_scale > 0) || !(opt.reach > 0) || !std::isfinite(opt.radius_scale) || !std::isfinite(opt.reach) ||
      !(opt.fade >= 0) || !std::isfinite(opt.fade))
    throw MeshError("joint_fillet: radius_scale and reach must be positive and finite, fade >= 0");
  if (!(parent_dir.norm() > 1e-12) || !(child_dir.norm() > 1e-12) || !(limb_radius > 0)) return std::nullopt;
  JointFillet f;
  f.joint = joint;
  f.child_axis = child_dir.normalized();
  const Eigen::Matrix3d M = f.relative = detail::nearest_rotation(relative.block<3, 3>(0, 0));
  const Vec3 b = M * f.child_axis, c = f.child_axis.cross(b);
  f.bend = std::atan2(c.norm(), f.child_axis.dot(b));
  if (!(f.bend > 1e-4) || f.bend > M_PI - 1e-3) return std::nullopt;
  f.bend_axis = c.normalized();
  f.swing = Eigen::AngleAxisd(f.bend, f.bend_axis).toRotationMatrix();
  // The rest of the child's motion is a twist about its own axis.
  const Eigen::Quaterniond q(Eigen::Matrix3d(f.swing.transpose() * M));
  f.twist = 2 * std::atan2(q.vec().dot(f.child_axis), q.w());
  Vec3 e = parent_dir.normalized() + f.child_axis;
  e -= e.dot(f.bend_axis) * f.bend_axis;
  if (!(e.norm() > 1e-9)) return std::nullopt;
  f.axis = e.normalized();
  f.inner = f.bend_axis.cross(f.axis);
  const double h = std::tan(f.bend / 2), shift = 1 / std::cos(f.bend / 2) - 1;
  // L_k, L_o, L_wide and L_kept of the header.
  const double sought = opt.radius_scale * limb_radius * h, outer = limb_radius * h / shift;
  const double wide = std::max(blend_extent, std::min({sought, opt.reach * min_bone_length, outer}));
  const double kept = std::min(wide, std::max(outer, sought));
  f.half_length = kept + detail::smoothstep(3 * (1 - outer / sought)) * (wide - kept);
  if (!(f.half_length > 0)) return std::nullopt;
  f.radius = f.half_length / h;
  f.weight = detail::smoothstep(f.bend / kOnset);
  if (opt.fade > 0) f.weight *= detail::smoothstep((f.radius / limb_radius / opt.fade - 2.0 / 3) * 3);
  return f;
}

}  // namespace dgmesh
