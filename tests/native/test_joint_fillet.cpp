// Joint fillets (joint_fillet.h): known answers for a straight chain along x bent about z.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dgmesh/errors.h"
#include "dgmesh/joint_fillet.h"

using namespace dgmesh;

namespace {

Eigen::Matrix4d turn(const Vec3& axis, double angle) {
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.block<3, 3>(0, 0) = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return M;
}

// Parent along x ending at the origin, child along x from it; weight blend 0.3, limb radius 0.5,
// bones 3.5 long.
std::optional<JointFillet> bend(const Eigen::Matrix4d& relative, double blend = 0.3) {
  return joint_fillet(relative, Vec3::Zero(), Vec3::UnitX(), Vec3::UnitX(), blend, 0.5, 3.5);
}

Vec3 map(const JointFillet& f, const Vec3& y, double wt = 1) {
  Eigen::Matrix3d R;
  return f.map(y, f.t_of(y), wt, R);
}

}  // namespace

TEST(JointFillet, NoneAtAStraightJointOrUnderAPureTwist) {
  EXPECT_FALSE(bend(Eigen::Matrix4d::Identity()));
  EXPECT_FALSE(bend(turn(Vec3::UnitX(), 1.0)));  // a twist about the child's own axis
}

TEST(JointFillet, NinetyDegreesIsTheArcOfTwiceTheRadiusTangentToBothBones) {
  const auto f = bend(turn(Vec3::UnitZ(), M_PI / 2));
  ASSERT_TRUE(f);
  // L = max(0.3, min(2 * 0.5 * tan 45, 0.5 * 3.5, 0.5 tan 45 / (1 / cos 45 - 1))) = 1, R_f = L / tan 45.
  EXPECT_NEAR(f->half_length, 1.0, 1e-12);
  EXPECT_NEAR(f->radius, 1.0, 1e-12);
  EXPECT_NEAR(f->bend, M_PI / 2, 1e-12);
  EXPECT_NEAR(f->twist, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(f->weight, 1.0);
  // The axis inside the band lies on the circle of radius 1 about (-1, 1, 0), from the parent's axis
  // at t = -1 (tangent to x) to the child's at t = 1 (tangent to y); the band's axis shortens to the
  // arc (pi / 2 over 2).
  double length = 0;
  Vec3 prev = map(*f, Vec3(-1, 0, 0));
  EXPECT_NEAR((prev - Vec3(-1, 0, 0)).norm(), 0, 1e-12);
  for (int k = 1; k <= 200; ++k) {
    const Vec3 p = map(*f, Vec3(-1 + 2.0 * k / 200, 0, 0));
    EXPECT_NEAR((p - Vec3(-1, 1, 0)).norm(), 1.0, 1e-12);
    length += (p - prev).norm();
    prev = p;
  }
  EXPECT_NEAR((prev - Vec3(0, 1, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR(length, M_PI / 2, 1e-4);
  // Cross-sections turn rigidly: a point off the axis keeps its offset, turned by the section's angle.
  const Vec3 mid = map(*f, Vec3(0, 0, 0)), off = map(*f, Vec3(0, 0.5, 0.2));
  EXPECT_NEAR((off - mid - Vec3(-0.5 * std::sin(M_PI / 4), 0.5 * std::cos(M_PI / 4), 0.2)).norm(), 0, 1e-12);
  // Outside the band: the parent's side stays, the child's side turns rigidly about the joint.
  EXPECT_NEAR((map(*f, Vec3(-2, 0.3, 0.1)) - Vec3(-2, 0.3, 0.1)).norm(), 0, 1e-12);
  EXPECT_NEAR((map(*f, Vec3(2, 0.3, 0.1)) - Vec3(-0.3, 2, 0.1)).norm(), 0, 1e-12);
  // Continuous across the band's ends.
  for (double t : {-1.0, 1.0}) {
    const Vec3 y(t, 0.4, -0.1), d(1e-7, 0, 0);
    EXPECT_NEAR((map(*f, y - d) - map(*f, y + d)).norm(), 0, 1e-6);
  }
}

TEST(JointFillet, TheBandIsAtLeastTheWeightBlendAndStopsShortOfTheOuterSide) {
  // A wide blend sets the band while the arc stays within one radius of the joint's corner (60
  // degrees: L_o = 0.5 tan 30 / (1 / cos 30 - 1) = 1.866): R_f = 1.5 / tan 30.
  const auto wide = bend(turn(Vec3::UnitZ(), M_PI / 3), 1.5);
  ASSERT_TRUE(wide);
  EXPECT_NEAR(wide->half_length, 1.5, 1e-12);
  EXPECT_NEAR(wide->radius, 1.5 / std::tan(M_PI / 6), 1e-12);
  // Wider than that at 90 degrees: capped at L_o = 0.5 / (sqrt 2 - 1), the arc one radius inside.
  const auto capped = bend(turn(Vec3::UnitZ(), M_PI / 2), 2.0);
  ASSERT_TRUE(capped);
  EXPECT_NEAR(capped->half_length, 0.5 / (std::sqrt(2.0) - 1), 1e-12);
  EXPECT_NEAR(capped->radius * (std::sqrt(2.0) - 1), 0.5, 1e-12);
  // At 135 degrees no band keeps both sides (L_o = 0.75 < 2 L_k / 3): the blend's band again.
  const auto folded = bend(turn(Vec3::UnitZ(), 0.75 * M_PI), 2.0);
  ASSERT_TRUE(folded);
  EXPECT_NEAR(folded->half_length, 2.0, 1e-12);
  // In between the band is given back to the blend continuously (a pose path stays continuous).
  double last = capped->half_length;
  for (double deg = 90.05; deg < 135; deg += 0.05) {
    const double L = bend(turn(Vec3::UnitZ(), deg * M_PI / 180), 2.0)->half_length;
    EXPECT_LT(std::abs(L - last), 0.01) << deg;
    last = L;
  }
  // 135 degrees: the arc may pass at most one radius inside the joint's corner,
  // R_f (1 / cos 67.5 - 1) = 0.5.
  const auto tight = bend(turn(Vec3::UnitZ(), 0.75 * M_PI));
  ASSERT_TRUE(tight);
  EXPECT_NEAR(tight->radius * (1 / std::cos(0.375 * M_PI) - 1), 0.5, 1e-12);
  const Vec3 corner = map(*tight, Vec3::Zero());
  EXPECT_NEAR(corner.norm(), 0.5, 1e-12);
}

TEST(JointFillet, TwistIsTheChildsTurnAboutItsOwnAxisSharedByWeight) {
  const double tau = 0.5;
  const auto f = bend(turn(Vec3::UnitZ(), M_PI / 2) * turn(Vec3::UnitX(), tau));
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->bend, M_PI / 2, 1e-12);
  EXPECT_NEAR(f->twist, tau, 1e-12);
  // Past the band with all of the twist: the child's full motion; with none: its swing alone.
  const Vec3 y(2, 0.3, 0.1);
  const Eigen::Matrix3d full = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix() *
                               Eigen::AngleAxisd(tau, Vec3::UnitX()).toRotationMatrix();
  EXPECT_NEAR((map(*f, y, 1) - full * y).norm(), 0, 1e-12);
  EXPECT_NEAR((map(*f, y, 0) - Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()) * y).norm(), 0, 1e-12);
}

TEST(JointFillet, BlendedInOverTheFirstTenDegrees) {
  const auto five = bend(turn(Vec3::UnitZ(), M_PI / 36));
  ASSERT_TRUE(five);
  EXPECT_NEAR(five->weight, 0.5, 1e-12);  // smoothstep at the onset's half
}

TEST(JointFillet, FadesOutWhereItsRadiusFallsBelowTheFadesLimbRadii) {
  JointFilletOptions o;
  o.fade = 1.2;
  // 90 degrees: R_f = 1 = 2 limb radii, no fade; 135 degrees: R_f = 0.62 limb radii, below 0.8: gone;
  // in between, smoothstep of (R_f / r / 1.2 - 2/3) * 3.
  const auto at = [&](double a) {
    return joint_fillet(turn(Vec3::UnitZ(), a), Vec3::Zero(), Vec3::UnitX(), Vec3::UnitX(), 0.3, 0.5, 3.5, o);
  };
  EXPECT_DOUBLE_EQ(at(M_PI / 2)->weight, 1.0);
  EXPECT_DOUBLE_EQ(at(0.75 * M_PI)->weight, 0.0);
  const auto mid = at(2 * M_PI / 3);  // R_f = r tan 60 / (1 / cos 60 - 1) / tan 60 = r
  const double q = (1.0 / 1.2 - 2.0 / 3) * 3;
  EXPECT_NEAR(mid->weight, q * q * (3 - 2 * q), 1e-12);
  o.fade = -1;
  EXPECT_THROW(at(M_PI / 2), MeshError);
}

TEST(JointFillet, RefusesNonFiniteInputAndBadOptions) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(joint_fillet(turn(Vec3::UnitZ(), 1.0), Vec3(nan, 0, 0), Vec3::UnitX(), Vec3::UnitX(), 0.3, 0.5, 3.5),
               MeshError);
  EXPECT_THROW(joint_fillet(turn(Vec3::UnitZ(), 1.0), Vec3::Zero(), Vec3::UnitX(), Vec3::UnitX(), 0.3, 0.5, 3.5,
                            JointFilletOptions{0.0, 0.5}),
               MeshError);
  EXPECT_FALSE(joint_fillet(turn(Vec3::UnitZ(), 1.0), Vec3::Zero(), Vec3::Zero(), Vec3::UnitX(), 0.3, 0.5, 3.5));
}
