// The input guard (device/input_guard.hpp), the one judge of a reading: invalid, non-finite or
// non-unit, stale, jumping or turning; the pose to use (the last good one when the reading cannot be);
// its limits brought into range; the unit-quaternion rule the bridge and trajectory files share.
#include "cariesim/device/input_guard.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cariesim {
namespace {

Pose at(const Vec3& p) { return Pose{p, Quat::Identity()}; }

TEST(InputGuard, AGoodReadingPassesNormalised) {
  InputGuard guard;
  Pose slightly_long = at(Vec3(1, 2, 3));
  slightly_long.q = Quat(1.0004, 0, 0, 0);  // within kUnitTolerance: rounding
  EXPECT_EQ(guard.judge(slightly_long), 0u);
  EXPECT_EQ(guard.pose().p, Vec3(1, 2, 3));
  EXPECT_NEAR(guard.pose().q.norm(), 1.0, 1e-15);
}

TEST(InputGuard, StaleReadingsAreFaultsButTheirPoseIsUsed) {
  InputGuard guard;  // stale after 50 ms
  EXPECT_EQ(guard.judge(at(Vec3(1, 0, 0)), true, 0.04), 0u);
  EXPECT_EQ(guard.judge(at(Vec3(1.1, 0, 0)), true, 0.06), static_cast<uint32_t>(kInputStale));
  EXPECT_EQ(guard.pose().p, Vec3(1.1, 0, 0));
  EXPECT_EQ(guard.judge(at(Vec3(1.1, 0, 0)), true, std::nan("")), static_cast<uint32_t>(kInputStale));
}

TEST(InputGuard, InvalidOrUnusableReadingsKeepTheLastGoodPose) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  InputGuard guard(InputLimits{}, at(Vec3(9, 9, 9)));
  // Before any good reading: the start pose.
  EXPECT_EQ(guard.judge(at(Vec3(nan, 0, 0))), static_cast<uint32_t>(kInputNonFinite));
  EXPECT_EQ(guard.pose().p, Vec3(9, 9, 9));
  EXPECT_EQ(guard.judge(at(Vec3(1, 0, 0))), 0u);
  Pose inf_quat = at(Vec3(2, 0, 0));
  inf_quat.q = Quat(inf, 0, 0, 0);
  Pose long_quat = at(Vec3(2, 0, 0));
  long_quat.q = Quat(2, 0, 0, 0);  // not a rotation: an error, not something to normalise
  Pose zero_quat = at(Vec3(2, 0, 0));
  zero_quat.q = Quat(0, 0, 0, 0);
  for (const Pose& bad : {inf_quat, long_quat, zero_quat}) {
    EXPECT_EQ(guard.judge(bad), static_cast<uint32_t>(kInputNonFinite));
    EXPECT_EQ(guard.pose().p, Vec3(1, 0, 0));
  }
  EXPECT_EQ(guard.judge(at(Vec3(3, 0, 0)), false), static_cast<uint32_t>(kInputInvalid));
  EXPECT_EQ(guard.pose().p, Vec3(1, 0, 0));
}

TEST(InputGuard, AJumpIsAFaultForOneReading) {
  InputGuard guard;  // 20 mm
  EXPECT_EQ(guard.judge(at(Vec3(0, 0, 0))), 0u);
  EXPECT_EQ(guard.judge(at(Vec3(100, 0, 0))), static_cast<uint32_t>(kInputJump));
  EXPECT_EQ(guard.pose().p, Vec3(100, 0, 0)) << "the pose is used; the step limits how far it follows";
  EXPECT_EQ(guard.judge(at(Vec3(100.5, 0, 0))), 0u);  // moving on from there: fine
  // A NaN reading in between does not hide a jump: it is measured from the last pose used.
  EXPECT_EQ(guard.judge(at(Vec3(std::nan(""), 0, 0))), static_cast<uint32_t>(kInputNonFinite));
  EXPECT_EQ(guard.judge(at(Vec3(0, 0, 0))), static_cast<uint32_t>(kInputJump));
}

TEST(InputGuard, ATurnIsAJump) {
  InputGuard guard;  // 0.5 rad
  EXPECT_EQ(guard.judge(at(Vec3::Zero())), 0u);
  Pose turned = at(Vec3::Zero());
  turned.q = Quat(Eigen::AngleAxisd(M_PI, Vec3::UnitX()));
  EXPECT_EQ(guard.judge(turned), static_cast<uint32_t>(kInputJump));
  Pose on = turned;  // turning on slowly from there
  on.q = turned.q * Quat(Eigen::AngleAxisd(0.01, Vec3::UnitY()));
  EXPECT_EQ(guard.judge(on), 0u);
}

TEST(InputGuard, ItsLimitsAreTheOnesGiven) {
  InputLimits tight;
  tight.max_jump = 5.0;
  tight.max_jump_rotation = 0.1;
  tight.stale_after = 0.2;
  InputGuard guard(tight);
  EXPECT_EQ(guard.judge(at(Vec3::Zero()), true, 0.15), 0u);
  EXPECT_EQ(guard.judge(at(Vec3(6, 0, 0)), true, 0.25), kInputJump | kInputStale);
  Pose turned = at(Vec3(6, 0, 0));
  turned.q = Quat(Eigen::AngleAxisd(0.2, Vec3::UnitZ()));
  EXPECT_EQ(guard.judge(turned), static_cast<uint32_t>(kInputJump));
}

TEST(InputGuard, OutOfRangeLimitsAreMadeSafe) {
  InputLimits bad;
  bad.stale_after = -5.0;
  bad.max_jump = std::nan("");
  bad.max_jump_rotation = std::numeric_limits<double>::infinity();
  const InputGuard guard(bad);
  EXPECT_DOUBLE_EQ(guard.limits().stale_after, 0.0);  // negative: every old reading is stale
  EXPECT_DOUBLE_EQ(guard.limits().max_jump, 20.0);    // not finite: the default
  EXPECT_DOUBLE_EQ(guard.limits().max_jump_rotation, 0.5);
}

TEST(InputGuard, ResetForgetsThePositionForTheJump) {
  InputGuard guard;
  EXPECT_EQ(guard.judge(at(Vec3::Zero())), 0u);
  guard.reset();
  EXPECT_EQ(guard.judge(at(Vec3(500, 0, 0))), 0u);
}

TEST(InputGuard, OneUnitRule) {
  EXPECT_TRUE(is_unit(Quat(1, 0, 0, 0)));
  EXPECT_TRUE(is_unit(Quat(1.0 + 0.9 * kUnitTolerance, 0, 0, 0)));
  EXPECT_FALSE(is_unit(Quat(1.0 + 1.1 * kUnitTolerance, 0, 0, 0)));
  EXPECT_FALSE(is_unit(Quat(std::nan(""), 0, 0, 0)));
  EXPECT_FALSE(usable_pose(Pose{Vec3(std::nan(""), 0, 0), Quat::Identity()}));
  EXPECT_TRUE(usable_pose(Pose{Vec3(1, 2, 3), Quat(0, 1, 0, 0)}));
}

}  // namespace
}  // namespace cariesim
