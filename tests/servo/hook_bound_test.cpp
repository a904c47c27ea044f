// The hook's holding force is bounded by the device: on a device whose maximum force is 5 N, the
// wrench of every cycle of the hook scenario (step, then the force safety layer, as the servo loop
// runs them) stays at or under 5 N, where the unbounded hook reaches about 9.8 N.
#include <gtest/gtest.h>

#include <vector>

#include "cariesim/device/safety.hpp"
#include "cariesim/render/step.hpp"
#include "support/hook_scenario.hpp"

namespace cariesim {
namespace {

TEST(HookBound, HoldingForceNeverExceedsTheDeviceMaximum) {
  test::HookScenario h = test::hook_scenario();
  const Trajectory t = test::hook_trajectory(h, 0.3, 1.0, 0.01);
  for (const double max_force : {1000.0, 5.0}) {
    Params p = h.params;
    p.limits.max_force = max_force;  // N
    State state(h.model, t.pose.front());
    ForceSafety safety(SafetyParams{0.0, 1.0});  // no ramp: judge the bound alone
    double largest = 0.0;
    int clamped = 0;
    const double dt = 0.001;
    for (double now = 0.0; now <= t.end(); now += dt) {
      const Pose hand = t.sample(now);
      StepOutput out = step(h.model, p, state, HapticInput{hand, dt});
      safety.filter(out.force, out.torque, out.input_faults, now);
      largest = std::max(largest, out.force.norm());
      clamped += (out.flags & kFlagForceClamped) != 0;
    }
    if (max_force > 100.0) {
      EXPECT_GT(largest, 8.0) << "the unbounded hook should pull back hard";
    } else {
      EXPECT_LE(largest, max_force + 1e-9);
      EXPECT_GT(largest, 0.99 * max_force);
      EXPECT_GT(clamped, 100) << "the clamp's flag reaches the output";
    }
  }
}

}  // namespace
}  // namespace cariesim
