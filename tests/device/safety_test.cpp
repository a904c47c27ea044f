// ForceSafety on its own: ramp, scale, staleness, non-finite and invalid input, jumps, the fault
// counter; it never clamps (the step's output stage does, tests/servo/safety_loop_test.cpp checks
// the rendered wrench through the loop).
#include "cariesim/device/safety.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cariesim {
namespace {

DeviceState reading(double stamp, const Vec3& p = Vec3::Zero()) {
  DeviceState s;
  s.pose.p = p;
  s.stamp = stamp;
  s.valid = true;
  return s;
}

SafetyParams no_ramp() {
  SafetyParams p;
  p.ramp_time = 0.0;
  return p;
}

TEST(ForceSafety, Defaults) {
  const ForceSafety safety;
  EXPECT_DOUBLE_EQ(safety.params().ramp_time, 1.0);
  EXPECT_DOUBLE_EQ(safety.params().stale_after, 0.05);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 1.0);
  EXPECT_DOUBLE_EQ(safety.params().max_jump, 20.0);
}

TEST(ForceSafety, PassesAWrenchWithinTheLimits) {
  ForceSafety safety(no_ramp());
  Vec3 f(1, 2, 3), t(10, 0, -5);
  safety.filter(f, t, reading(1.0), 1.0);
  EXPECT_EQ(f, Vec3(1, 2, 3));
  EXPECT_EQ(t, Vec3(10, 0, -5));
  EXPECT_EQ(safety.flags(), 0u);
  EXPECT_EQ(safety.faults(), 0u);
}

TEST(ForceSafety, NeverClampsOrRaisesAWrench) {
  // Far above any device's limits: passed unchanged (the step's output stage is the one clamp), and
  // never a clamp flag.
  ForceSafety safety(no_ramp());
  Vec3 f(300, 400, 0), t(0, 0, -1e4);
  safety.filter(f, t, reading(0.0), 0.0);
  EXPECT_EQ(f, Vec3(300, 400, 0));
  EXPECT_EQ(t, Vec3(0, 0, -1e4));
  EXPECT_EQ(safety.flags() & (kSafetyClampedForce | kSafetyClampedTorque), 0u);
  EXPECT_EQ(safety.flags(), 0u);
}

TEST(ForceSafety, RampsInLinearlyFromStart) {
  SafetyParams p;
  p.ramp_time = 1.0;
  ForceSafety safety(p);
  for (double now : {10.0, 10.25, 10.5, 11.0, 12.0}) {
    Vec3 f(0, 0, 8), t(0, 0, 0);
    safety.filter(f, t, reading(now), now);
    EXPECT_NEAR(f.z(), 8.0 * std::min(1.0, now - 10.0), 1e-12) << now;
    EXPECT_EQ((safety.flags() & kSafetyRamping) != 0, now - 10.0 < 1.0) << now;
  }
}

TEST(ForceSafety, RampsInAgainAfterAFault) {
  SafetyParams p;
  p.ramp_time = 0.1;
  ForceSafety safety(p);
  Vec3 f(0, 0, 4), t = Vec3::Zero();
  safety.filter(f, t, reading(0.0), 0.0);
  f = Vec3(0, 0, 4);
  safety.filter(f, t, reading(0.2), 0.2);
  EXPECT_DOUBLE_EQ(f.z(), 4.0);  // fully ramped in
  DeviceState bad = reading(0.201);
  bad.valid = false;
  f = Vec3(0, 0, 4);
  safety.filter(f, t, bad, 0.201);
  EXPECT_TRUE(f.isZero());
  f = Vec3(0, 0, 4);
  safety.filter(f, t, reading(0.202), 0.202);  // the fault cleared: from zero again
  EXPECT_NEAR(f.z(), 0.0, 1e-12);
  f = Vec3(0, 0, 4);
  safety.filter(f, t, reading(0.252), 0.252);
  EXPECT_NEAR(f.z(), 2.0, 1e-9);
}

TEST(ForceSafety, ScaleLowersForceAndTorque) {
  ForceSafety safety(no_ramp());
  safety.set_force_scale(0.5);
  Vec3 f(0, 0, 10), t(0, 0, 100);
  safety.filter(f, t, reading(0.0), 0.0);
  EXPECT_DOUBLE_EQ(f.z(), 5.0);
  EXPECT_DOUBLE_EQ(t.z(), 50.0);
  // The scale stays in [0, 1] (it can only lower a wrench); NaN gives 0.
  safety.set_force_scale(3.0);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 1.0);
  safety.set_force_scale(-1.0);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 0.0);
  safety.set_force_scale(std::nan(""));
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 0.0);
}

TEST(ForceSafety, StaleReadingsZeroTheForce) {
  ForceSafety safety(no_ramp());
  Vec3 f(0, 0, 5), t(1, 0, 0);
  safety.filter(f, t, reading(1.0), 1.04);  // 40 ms old: fine
  EXPECT_DOUBLE_EQ(f.z(), 5.0);
  f = Vec3(0, 0, 5);
  safety.filter(f, t, reading(1.0), 1.06);  // 60 ms old: stale
  EXPECT_TRUE(f.isZero());
  EXPECT_TRUE(t.isZero());
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyStale));
  EXPECT_EQ(safety.faults(), 1u);
}

TEST(ForceSafety, NonFiniteInputOrWrenchZeroesTheForce) {
  ForceSafety safety(no_ramp());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  // A NaN position, an infinite quaternion, a NaN force, an infinite torque.
  DeviceState nan_pose = reading(0.0, Vec3(nan, 0, 0));
  DeviceState inf_quat = reading(0.0);
  inf_quat.pose.q = Quat(inf, 0, 0, 0);
  struct Case {
    DeviceState in;
    Vec3 f, t;
  };
  const Case cases[] = {{nan_pose, Vec3(1, 1, 1), Vec3::Zero()},
                        {inf_quat, Vec3(1, 1, 1), Vec3::Zero()},
                        {reading(0.0), Vec3(nan, 0, 1), Vec3::Zero()},
                        {reading(0.0), Vec3(0, 0, 1), Vec3(0, inf, 0)}};
  uint64_t faults = 0;
  for (const Case& c : cases) {
    Vec3 f = c.f, t = c.t;
    safety.filter(f, t, c.in, 0.0);
    EXPECT_TRUE(f.isZero());
    EXPECT_TRUE(t.isZero());
    EXPECT_NE(safety.flags() & kSafetyNonFinite, 0u);
    EXPECT_EQ(safety.faults(), ++faults);
  }
}

TEST(ForceSafety, InvalidInputZeroesTheForce) {
  ForceSafety safety(no_ramp());
  DeviceState s = reading(0.0);
  s.valid = false;
  Vec3 f(0, 0, 3), t(0, 0, 0);
  safety.filter(f, t, s, 0.0);
  EXPECT_TRUE(f.isZero());
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyInvalidInput));
}

TEST(ForceSafety, AJumpIsAFaultForOneReading) {
  ForceSafety safety(no_ramp());
  Vec3 f(0, 0, 3), t = Vec3::Zero();
  safety.filter(f, t, reading(0.0, Vec3(0, 0, 0)), 0.0);
  EXPECT_DOUBLE_EQ(f.z(), 3.0);
  f = Vec3(0, 0, 3);
  safety.filter(f, t, reading(0.001, Vec3(100, 0, 0)), 0.001);  // 100 mm in one reading
  EXPECT_TRUE(f.isZero());
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyJump));
  f = Vec3(0, 0, 3);
  safety.filter(f, t, reading(0.002, Vec3(100.5, 0, 0)), 0.002);  // moving on from there: fine
  EXPECT_DOUBLE_EQ(f.z(), 3.0);
  // A NaN reading in between does not hide a jump: it is compared with the last finite one.
  f = Vec3(0, 0, 3);
  safety.filter(f, t, reading(0.003, Vec3(std::nan(""), 0, 0)), 0.003);
  f = Vec3(0, 0, 3);
  safety.filter(f, t, reading(0.004, Vec3(0, 0, 0)), 0.004);
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyJump));
}

// Issue #14 item 6: a 180-degree turn between two readings is a jump like a 100 mm move (it used to
// pass, and the step rendered 463 N·mm at once with no flag).
TEST(ForceSafety, ATurnIsAFaultLikeAJump) {
  ForceSafety safety(no_ramp());
  Vec3 f(0, 0, 3), t(0, 0, 40);
  safety.filter(f, t, reading(0.0), 0.0);
  EXPECT_DOUBLE_EQ(t.z(), 40.0);
  DeviceState turned = reading(0.001);
  turned.pose.q = Quat(Eigen::AngleAxisd(M_PI, Vec3::UnitX()));
  f = Vec3(0, 0, 3);
  t = Vec3(0, 0, 40);
  safety.filter(f, t, turned, 0.001);
  EXPECT_TRUE(f.isZero());
  EXPECT_TRUE(t.isZero());
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyJump));
  // Turning on slowly from there (0.01 rad per reading) is fine.
  DeviceState on = reading(0.002);
  on.pose.q = turned.pose.q * Quat(Eigen::AngleAxisd(0.01, Vec3::UnitY()));
  t = Vec3(0, 0, 40);
  safety.filter(f, t, on, 0.002);
  EXPECT_DOUBLE_EQ(t.z(), 40.0);
  EXPECT_EQ(safety.flags(), 0u);
}

TEST(ForceSafety, OutOfRangeParametersAreMadeSafe) {
  SafetyParams p;
  p.stale_after = -5.0;
  p.max_jump = std::nan("");
  p.ramp_time = std::numeric_limits<double>::infinity();
  p.force_scale = 7.0;
  const ForceSafety safety(p);
  EXPECT_DOUBLE_EQ(safety.params().stale_after, 0.0);  // negative: every old reading is stale
  EXPECT_DOUBLE_EQ(safety.params().max_jump, 20.0);    // not finite: the default
  EXPECT_DOUBLE_EQ(safety.params().ramp_time, 1.0);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 1.0);
}

TEST(ForceSafety, ResetRestartsTheRampAndForgetsThePosition) {
  SafetyParams p;
  p.ramp_time = 1.0;
  ForceSafety safety(p);
  Vec3 f(0, 0, 2), t = Vec3::Zero();
  safety.filter(f, t, reading(0.0), 0.0);
  safety.filter(f, t, reading(5.0), 5.0);
  safety.reset();
  f = Vec3(0, 0, 2);
  safety.filter(f, t, reading(6.0, Vec3(500, 0, 0)), 6.0);  // no jump after a reset, ramp from 0
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyRamping));
  EXPECT_DOUBLE_EQ(f.z(), 0.0);
}

}  // namespace
}  // namespace cariesim
