// ForceSafety on its own: ramp, scale, the input guard's verdict (input_guard_test.cpp judges the
// readings) and a non-finite wrench zeroing the force, the fault counter; it never clamps (the step's
// output stage does, tests/servo/safety_loop_test.cpp checks the rendered wrench through the loop).
#include "cariesim/device/safety.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

#include "cariesim/device/input_guard.hpp"

namespace cariesim {
namespace {

SafetyParams no_ramp() {
  SafetyParams p;
  p.ramp_time = 0.0;
  return p;
}

TEST(ForceSafety, Defaults) {
  const ForceSafety safety;
  EXPECT_DOUBLE_EQ(safety.params().ramp_time, 1.0);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 1.0);
}

TEST(ForceSafety, PassesAWrenchWithinTheLimits) {
  ForceSafety safety(no_ramp());
  Vec3 f(1, 2, 3), t(10, 0, -5);
  safety.filter(f, t, 0, 1.0);
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
  safety.filter(f, t, 0, 0.0);
  EXPECT_EQ(f, Vec3(300, 400, 0));
  EXPECT_EQ(t, Vec3(0, 0, -1e4));
  EXPECT_EQ(safety.flags(), 0u);
}

TEST(ForceSafety, RampsInLinearlyFromStart) {
  SafetyParams p;
  p.ramp_time = 1.0;
  ForceSafety safety(p);
  for (double now : {10.0, 10.25, 10.5, 11.0, 12.0}) {
    Vec3 f(0, 0, 8), t(0, 0, 0);
    safety.filter(f, t, 0, now);
    EXPECT_NEAR(f.z(), 8.0 * std::min(1.0, now - 10.0), 1e-12) << now;
    EXPECT_EQ((safety.flags() & kSafetyRamping) != 0, now - 10.0 < 1.0) << now;
  }
}

TEST(ForceSafety, RampsInAgainAfterAFault) {
  SafetyParams p;
  p.ramp_time = 0.1;
  ForceSafety safety(p);
  Vec3 f(0, 0, 4), t = Vec3::Zero();
  safety.filter(f, t, 0, 0.0);
  f = Vec3(0, 0, 4);
  safety.filter(f, t, 0, 0.2);
  EXPECT_DOUBLE_EQ(f.z(), 4.0);  // fully ramped in
  f = Vec3(0, 0, 4);
  safety.filter(f, t, kInputInvalid, 0.201);
  EXPECT_TRUE(f.isZero());
  f = Vec3(0, 0, 4);
  safety.filter(f, t, 0, 0.202);  // the fault cleared: from zero again
  EXPECT_NEAR(f.z(), 0.0, 1e-12);
  f = Vec3(0, 0, 4);
  safety.filter(f, t, 0, 0.252);
  EXPECT_NEAR(f.z(), 2.0, 1e-9);
}

TEST(ForceSafety, ScaleLowersForceAndTorque) {
  ForceSafety safety(no_ramp());
  safety.set_force_scale(0.5);
  Vec3 f(0, 0, 10), t(0, 0, 100);
  safety.filter(f, t, 0, 0.0);
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

// Each fault the input guard reports zeroes the wrench and counts, with its own flag.
TEST(ForceSafety, EveryInputFaultZeroesTheForce) {
  ForceSafety safety(no_ramp());
  const std::pair<uint32_t, uint32_t> cases[] = {{kInputInvalid, kSafetyInvalidInput},
                                                 {kInputNonFinite, kSafetyNonFinite},
                                                 {kInputStale, kSafetyStale},
                                                 {kInputJump, kSafetyJump},
                                                 {kInputStale | kInputJump, kSafetyStale | kSafetyJump}};
  uint64_t faults = 0;
  for (const auto& [input, flags] : cases) {
    Vec3 f(0, 0, 5), t(1, 0, 0);
    safety.filter(f, t, input, 1.0);
    EXPECT_TRUE(f.isZero()) << input;
    EXPECT_TRUE(t.isZero()) << input;
    EXPECT_EQ(safety.flags(), flags) << input;
    EXPECT_EQ(safety.faults(), ++faults);
  }
  // No fault: the wrench passes.
  Vec3 f(0, 0, 5), t(1, 0, 0);
  safety.filter(f, t, 0, 1.0);
  EXPECT_DOUBLE_EQ(f.z(), 5.0);
  EXPECT_EQ(safety.flags(), 0u);
}

TEST(ForceSafety, ANonFiniteWrenchOrTimeZeroesTheForce) {
  ForceSafety safety(no_ramp());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    Vec3 f, t;
    double now;
  };
  const Case cases[] = {{Vec3(nan, 0, 1), Vec3::Zero(), 0.0},
                        {Vec3(0, 0, 1), Vec3(0, inf, 0), 0.0},
                        {Vec3(0, 0, 1), Vec3::Zero(), nan}};
  uint64_t faults = 0;
  for (const Case& c : cases) {
    Vec3 f = c.f, t = c.t;
    safety.filter(f, t, 0, c.now);
    EXPECT_TRUE(f.isZero());
    EXPECT_TRUE(t.isZero());
    EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyNonFinite));
    EXPECT_EQ(safety.faults(), ++faults);
  }
}

TEST(ForceSafety, OutOfRangeParametersAreMadeSafe) {
  SafetyParams p;
  p.ramp_time = std::numeric_limits<double>::infinity();
  p.force_scale = 7.0;
  const ForceSafety safety(p);
  EXPECT_DOUBLE_EQ(safety.params().ramp_time, 1.0);
  EXPECT_DOUBLE_EQ(safety.params().force_scale, 1.0);
  p.ramp_time = -1.0;
  EXPECT_DOUBLE_EQ(ForceSafety(p).params().ramp_time, 0.0);
}

TEST(ForceSafety, ResetRestartsTheRamp) {
  SafetyParams p;
  p.ramp_time = 1.0;
  ForceSafety safety(p);
  Vec3 f(0, 0, 2), t = Vec3::Zero();
  safety.filter(f, t, 0, 0.0);
  safety.filter(f, t, 0, 5.0);
  safety.reset();
  f = Vec3(0, 0, 2);
  safety.filter(f, t, 0, 6.0);  // ramp from 0 again
  EXPECT_EQ(safety.flags(), static_cast<uint32_t>(kSafetyRamping));
  EXPECT_DOUBLE_EQ(f.z(), 0.0);
}

}  // namespace
}  // namespace cariesim

namespace cariesim {
namespace {

TEST(ForceStop, ARequestedStopZeroesEveryLoopsForceFromTheNextCycleUntilCleared) {
  ForceSafety a, b;
  SafetyParams no_ramp;
  no_ramp.ramp_time = 0.0;
  ForceSafety c(no_ramp);
  Vec3 f(1, 2, 3), t(4, 5, 6);
  c.filter(f, t, 0, 0.0);
  ASSERT_EQ(f, Vec3(1, 2, 3));
  request_force_stop();
  EXPECT_TRUE(force_stop_requested());
  for (ForceSafety* s : {&a, &b, &c}) {
    Vec3 force(1, 2, 3), torque(4, 5, 6);
    s->filter(force, torque, 0, 1.0);
    EXPECT_EQ(force, Vec3::Zero());
    EXPECT_EQ(torque, Vec3::Zero());
    EXPECT_NE(s->flags() & kSafetyStopped, 0u);
    EXPECT_NE(s->flags() & kSafetyFaultMask, 0u);
  }
  clear_force_stop();
  f = Vec3(1, 2, 3);
  c.filter(f, t, 0, 2.0);
  EXPECT_EQ(c.flags() & kSafetyStopped, 0u);
  EXPECT_EQ(f, Vec3(1, 2, 3));  // no ramp configured
}

}  // namespace
}  // namespace cariesim
