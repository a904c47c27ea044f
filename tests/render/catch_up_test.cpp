// Catching up (docs/step.md, "Catching up"): the state and the flags tell the truth when the graphic
// tool is away from the hand with nothing touching it. On the real arch, a trajectory that starts with
// the tip 2 mm inside 46's crown rendered 11.9 N at once in the state "free" while the graphic tool
// came down from its home pose; a hand that passed through the crown rendered the coupling's pull
// (13.6 N), also "free" and unflagged. Now a start away from the hand ramps the force in from zero
// over kCatchUpRamp, and every free step whose tool is short of the hand says kFlagCatchingUp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

const Model& real_arch() {
  static const Model model = build_model(load_scene("real-arch"));
  return model;
}

// 46's highest cusp tip (world mm, real-arch's frame; the scan's highest vertex of tooth46).
const Vec3 kCusp46(-24.50, -0.51, 7.49);

struct Truth {
  double free_force = 0.0;    // N, largest force rendered in the free state
  int free_lagging = 0;       // free steps whose graphic tool was more than 0.01 mm from the hand
  int unflagged_lagging = 0;  // of those, the ones without kFlagCatchingUp
  double force_step = 0.0;    // N, largest change of the force between two steps
  double force_rise = 0.0;    // N, largest rise of the force's magnitude between two steps
  double final_force = 0.0;   // N, at the end
  double first_force = 0.0;   // N, at the first step
  InteractionState final_state = InteractionState::Free;
};

Truth run(const Trajectory& t) {
  const Model& m = real_arch();
  const std::vector<SimSample> samples = simulate(m, t, 1000.0);
  Truth out;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const StepOutput& o = samples[i].out;
    if (i > 0) {
      out.force_step = std::max(out.force_step, (o.force - samples[i - 1].out.force).norm());
      out.force_rise = std::max(out.force_rise, o.force.norm() - samples[i - 1].out.force.norm());
    }
    if (o.state != InteractionState::Free) continue;
    out.free_force = std::max(out.free_force, o.force.norm());
    if ((o.graphic.p - o.haptic.p).norm() > 0.01) {
      ++out.free_lagging;
      if ((o.flags & kFlagCatchingUp) == 0) ++out.unflagged_lagging;
    }
  }
  out.final_force = samples.back().out.force.norm();
  out.first_force = samples.front().out.force.norm();
  out.final_state = samples.back().out.state;
  std::printf(
      "free force max %.3f N, free lagging steps %d (unflagged %d), force step max %.3f N (rise %.3f N), "
      "final "
      "%.3f N %s\n",
      out.free_force, out.free_lagging, out.unflagged_lagging, out.force_step, out.force_rise,
      out.final_force, state_name(out.final_state));
  return out;
}

TEST(CatchUp, AStartInsideAToothRampsTheForceIn) {
  // The hand starts with the tip 2 mm inside 46's cusp and stays there: the graphic tool starts at the
  // home pose (the start is not clear) and comes down onto the cusp.
  const Quat q = real_arch().tool_home.q;
  Trajectory t;
  t.add(0.0, Pose{kCusp46 - Vec3(0, 0, 2.0), q});
  t.add(1.0, Pose{kCusp46 - Vec3(0, 0, 2.0), q});
  const Truth truth = run(t);
  EXPECT_GT(truth.free_lagging, 0);  // the tool did come down from its home pose
  EXPECT_EQ(truth.unflagged_lagging, 0);
  EXPECT_LE(truth.first_force, 22.0 * 0.001 / kCatchUpRamp + 1e-9);  // main: 11.9 N at once
  EXPECT_LE(truth.force_rise, 22.0 * 0.001 / kCatchUpRamp + 0.05);  // ramped in, not struck at once
  // Held on the cusp with the hand 2 mm inside: the contact's force, in the state that says so.
  EXPECT_EQ(truth.final_state, InteractionState::Sliding);
  EXPECT_GT(truth.final_force, 1.0);
}

TEST(CatchUp, AHandThroughACrownIsFlaggedWhileTheToolCatchesUp) {
  // The hand passes straight through 46's crown from buccal to lingual, 5.5 mm below its cusp tip,
  // then rises 4.5 mm above the cusp and rests: the tool, held on the buccal face, slides up over the
  // cusp and comes free millimetres from the hand. Main rendered up to 13.6 N in "free" while it caught up.
  const Quat q = real_arch().tool_home.q;
  const double z = kCusp46.z() - 5.5;
  Trajectory t;
  t.add(0.0, Pose{Vec3(-32.0, kCusp46.y(), z), q});
  t.add(0.2, Pose{Vec3(-32.0, kCusp46.y(), z), q});
  t.add(0.5, Pose{Vec3(-11.0, kCusp46.y(), z), q});
  t.add(0.7, Pose{Vec3(-11.0, kCusp46.y(), 12.0), q});
  t.add(1.7, Pose{Vec3(-11.0, kCusp46.y(), 12.0), q});
  const Truth truth = run(t);
  EXPECT_GT(truth.free_lagging, 0);       // it did come free away from the hand
  EXPECT_EQ(truth.unflagged_lagging, 0);  // main: 19 such steps, up to 13.6 N, said only "free"
  EXPECT_LE(truth.force_step, 3.0);       // the coupling's pull fades as the tool catches up
  EXPECT_EQ(truth.final_state, InteractionState::Free);
  EXPECT_EQ(truth.final_force, 0.0);
}

}  // namespace
}  // namespace cariesim
