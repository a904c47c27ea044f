// End to end: a headless run of the engine on the friction block is recorded through the Recorder;
// the replay device then drives a fresh engine state with the recorded haptic poses on the servo
// clock, and the engine reproduces the recorded graphic tool, force and states (the step is
// deterministic), while recorded_graphic() gives the ghost at the same times.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/record/replay.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "record/record_support.hpp"

namespace cariesim {
namespace {

// The servo sample the loop would record for a step.
ServoSample to_sample(const SimSample& s) {
  ServoSample out;
  out.t = s.t;
  out.haptic = s.out.haptic;
  out.graphic = s.out.graphic;
  out.force = s.out.force;
  out.torque = s.out.torque;
  out.depth = static_cast<float>(s.out.depth);
  out.step_us = static_cast<float>(s.out.step_us);
  out.soft_tissue_force = static_cast<float>(s.out.soft_tissue_force);
  out.step_flags = s.out.flags;
  out.contacts = static_cast<uint16_t>(s.out.contacts);
  out.lesion = static_cast<int8_t>(s.out.lesion);
  out.state = s.out.state;
  return out;
}

TEST(ReplayEngine, ReplayReproducesTheRecordedSession) {
  BuildOptions options;
  options.cache_dir = std::filesystem::path(CARIESIM_BINARY_DIR) / "test-cache";
  const Model model = build_model(load_scene("friction-block"), options);
  const double rate = 1000.0;  // Hz

  // From home down onto the caries top (0.3 mm below the surface), then a slide along +x.
  const Pose home = model.tool_home;
  Pose above = home;
  above.p = Vec3(-20.0, 0.0, 1.0);
  Pose pressed = home;
  pressed.p = Vec3(-20.0, 0.0, 0.05 - 0.3);
  Pose slid = pressed;
  slid.p.x() = -12.0;
  Trajectory trajectory;
  trajectory.add(0.0, home);
  trajectory.add(0.3, above);
  trajectory.add(0.6, pressed);
  trajectory.add(1.2, slid);
  const std::vector<SimSample> run = simulate(model, trajectory, rate);

  test::ScratchDir dir("replay_engine");
  const auto file = dir / "session.db";
  {
    SessionInfo info;
    info.scene = "friction-block";
    info.rate_hz = rate;
    Recorder recorder(file, info);
    recorder.start();
    for (const SimSample& s : run)
      while (!recorder.queue().push(to_sample(s))) std::this_thread::yield();
    recorder.stop();
  }

  const auto device = make_replay_device(file);
  ReplayDevice& replay = *device;
  ASSERT_EQ(replay.size(), run.size());
  State state(model, replay.read(0.0).pose);
  int sliding = 0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const double now = static_cast<double>(i) / rate;
    // The file is streamed ahead of the servo clock; this loop runs faster than real time, so it
    // waits for the loader as the real-time servo thread never has to.
    for (int wait = 0; !replay.ready(now) && wait < 10000; ++wait)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    const StepOutput out = step(model, state, HapticInput{replay.read(now).pose, 1.0 / rate});
    const StepOutput& recorded = run[i].out;
    ASSERT_LT((out.graphic.p - recorded.graphic.p).norm(), 1e-9) << i;
    ASSERT_LT((out.force - recorded.force).norm(), 1e-9) << i;
    ASSERT_EQ(out.state, recorded.state) << i;
    ASSERT_LT((replay.recorded_graphic(now).p - recorded.graphic.p).norm(), 1e-12) << i;
    sliding += out.state == InteractionState::Sliding ? 1 : 0;
  }
  EXPECT_GT(sliding, 300) << "the run never reached the block";
  EXPECT_GT(run.back().out.force.norm(), 0.1);
}

}  // namespace
}  // namespace cariesim
