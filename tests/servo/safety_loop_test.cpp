// Issue 5 acceptance: "a device feeding NaN, a 100 mm jump, and then silence gets zero or clamped
// force, never over the limit". The real ServoLoop runs the real engine on friction-block, driven by
// a device with low limits that presses the tool into the block (the force reaches the limit), then
// sends NaN, then jumps 100 mm, then falls silent. Every rendered wrench is checked, cycle by cycle:
// the one clamp (the step's output stage, against the device's limits) holds through the safety
// layer, and its flag reaches the samples (the step's flags).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "cariesim/device/safety.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"

namespace cariesim {
namespace {

// The phases, also reported as the reading's `buttons` so each sample says where it was.
enum Phase : uint32_t { kPress = 1, kNaN = 2, kJump = 3, kSilence = 4 };

class GlitchDevice : public Device {
 public:
  static constexpr uint64_t kPressEnd = 400, kNaNEnd = 450, kJumpEnd = 600, kEnd = 800;

  GlitchDevice(const Model& m, const DeviceLimits& limits) : home_(m.tool_home), limits_(limits) {}
  [[nodiscard]] DeviceInfo info() const override { return DeviceInfo{"glitch", "test", limits_, true}; }
  DeviceState read(double now) override {
    const uint64_t k = reads_.fetch_add(1);
    if (k >= kJumpEnd) {
      // Silence: the last reading again, its stamp frozen.
      last_.buttons = kSilence;
      return last_;
    }
    DeviceState s;
    s.stamp = now;
    s.sequence = k + 1;
    s.valid = true;
    s.pose.q = home_.q;
    // Down from the home pose to 3 mm inside the block, then hold.
    const Vec3 press(home_.p.x(), 0.0, -3.0);
    const double u = std::min(1.0, static_cast<double>(k) / 200.0);
    s.pose.p = home_.p + u * (press - home_.p);
    s.buttons = kPress;
    if (k >= kPressEnd && k < kNaNEnd) {
      s.pose.p.x() = std::numeric_limits<double>::quiet_NaN();
      s.buttons = kNaN;
    } else if (k >= kNaNEnd) {
      s.pose.p = press + Vec3(100.0, 0.0, 0.0);
      s.buttons = kJump;
      frozen_stamp_.store(now);
    }
    last_ = s;
    return s;
  }
  void write(const Vec3& /*force*/, const Vec3& /*torque*/) override {}

  [[nodiscard]] uint64_t reads() const { return reads_.load(); }
  [[nodiscard]] double frozen_stamp() const { return frozen_stamp_.load(); }

 private:
  Pose home_;
  DeviceLimits limits_;
  DeviceState last_;
  std::atomic<uint64_t> reads_{0};
  std::atomic<double> frozen_stamp_{0.0};
};

TEST(SafetyAcceptance, NaNJumpAndSilenceGetZeroOrClampedForce) {
  Model m = test::friction_block();
  DeviceLimits limits;
  limits.max_force = 1.0;  // low, so pressing 3 mm into the block reaches it
  limits.max_torque = 20.0;
  GlitchDevice device(m, limits);
  SpscQueue<ServoSample> queue(20000);
  ServoOptions o;
  o.realtime = false;
  o.record = &queue;
  o.safety.ramp_time = 0.05;
  ServoLoop loop(m, device, o);
  loop.start();
  ASSERT_TRUE(test::wait_for([&] { return device.reads() >= GlitchDevice::kEnd; }));
  loop.stop();
  std::vector<ServoSample> samples;
  ServoSample s;
  while (queue.pop(s)) samples.push_back(s);
  ASSERT_EQ(loop.dropped_samples(), 0u);
  ASSERT_GE(samples.size(), GlitchDevice::kEnd);

  const double silence_from = device.frozen_stamp();
  int clamped_in_press = 0, nan_cycles = 0, jump_zeroed = 0, stale_cycles = 0, after_jump_force = 0;
  bool first_jump = true;
  for (const ServoSample& x : samples) {
    // Never over the limits, never NaN.
    ASSERT_TRUE(x.force.allFinite() && x.torque.allFinite()) << "t = " << x.t;
    EXPECT_LE(x.force.norm(), limits.max_force + 1e-9) << "t = " << x.t;
    EXPECT_LE(x.torque.norm(), limits.max_torque + 1e-9) << "t = " << x.t;
    const bool zero = x.force.isZero() && x.torque.isZero();
    switch (x.buttons) {
      case kPress:
        // The step clamped (its flag), force safety did not (it never clamps).
        clamped_in_press += (x.step_flags & kFlagForceClamped) != 0;
        EXPECT_EQ(x.safety_flags & ~static_cast<uint32_t>(kSafetyRamping), 0u) << "t = " << x.t;
        break;
      case kNaN:
        // Non-finite input: exactly zero.
        EXPECT_TRUE(zero) << "t = " << x.t;
        EXPECT_NE(x.safety_flags & kSafetyNonFinite, 0u);
        ++nan_cycles;
        break;
      case kJump:
        // The jump itself is a fault (zero); afterwards the force ramps in again, clamped.
        if (first_jump) {
          EXPECT_TRUE(zero);
          EXPECT_NE(x.safety_flags & kSafetyJump, 0u);
          jump_zeroed += zero;
          first_jump = false;
        } else {
          after_jump_force += x.force.norm() > 0.0;
        }
        break;
      case kSilence:
        // Silence: once the last reading is older than the stale limit, zero.
        if (x.t - silence_from > 0.05 + 1e-9) {
          EXPECT_TRUE(zero) << "t = " << x.t;
          EXPECT_NE(x.safety_flags & kSafetyStale, 0u);
          ++stale_cycles;
        }
        break;
      default:
        ADD_FAILURE() << "sample without a phase";
    }
  }
  // The sequence really exercised each case.
  EXPECT_GT(clamped_in_press, 0);
  EXPECT_EQ(nan_cycles, static_cast<int>(GlitchDevice::kNaNEnd - GlitchDevice::kPressEnd));
  EXPECT_EQ(jump_zeroed, 1);
  EXPECT_GT(after_jump_force, 0);
  EXPECT_GT(stale_cycles, 50);
  EXPECT_GT(loop.timing().cycles, 0u);
}

// One input guard, one parameter set: the model's InputLimits decide both the step's jump flag and
// force safety's zeroing, cycle by cycle. A device steps 7 mm once on a model whose limit is 5 mm
// (the default is 20): that cycle, and only that one, is a jump for both.
class StepDevice : public Device {
 public:
  static constexpr uint64_t kStepAt = 100, kEnd = 300;
  explicit StepDevice(const Model& m) : home_(m.tool_home) {}
  [[nodiscard]] DeviceInfo info() const override { return DeviceInfo{"step", "test", {}, true}; }
  DeviceState read(double now) override {
    const uint64_t k = reads_.fetch_add(1);
    DeviceState s;
    s.stamp = now;
    s.sequence = k + 1;
    s.valid = true;
    s.pose = home_;
    if (k >= kStepAt) s.pose.p.x() += 7.0;  // mm, in free space above the block
    return s;
  }
  void write(const Vec3& /*force*/, const Vec3& /*torque*/) override {}
  [[nodiscard]] uint64_t reads() const { return reads_.load(); }

 private:
  Pose home_;
  std::atomic<uint64_t> reads_{0};
};

TEST(SafetyAcceptance, TheStepAndSafetyJudgeJumpsByTheModelsLimits) {
  Model m = test::friction_block();
  m.settings.input.max_jump = 5.0;  // mm
  StepDevice device(m);
  SpscQueue<ServoSample> queue(20000);
  ServoOptions o;
  o.realtime = false;
  o.record = &queue;
  o.safety.ramp_time = 0.0;
  ServoLoop loop(m, device, o);
  loop.start();
  ASSERT_TRUE(test::wait_for([&] { return device.reads() >= StepDevice::kEnd; }));
  loop.stop();
  int jumps = 0;
  ServoSample x;
  while (queue.pop(x)) {
    const bool step_jump = (x.step_flags & kFlagJumpLimited) != 0;
    const bool safety_jump = (x.safety_flags & kSafetyJump) != 0;
    EXPECT_EQ(step_jump, safety_jump) << "t = " << x.t;
    if (safety_jump) {
      EXPECT_TRUE(x.force.isZero()) << "t = " << x.t;
    }
    jumps += safety_jump;
  }
  EXPECT_EQ(jumps, 1);
}

}  // namespace
}  // namespace cariesim
