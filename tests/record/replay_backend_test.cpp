// The record module's replay backend of the device factory (register_replay_device,
// record/replay.hpp): `replay:FILE[:loop]` makes a ReplayDevice (device/replay.hpp) over the
// recording that plays the recorded haptic poses.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/record/replay.hpp"

namespace cariesim {
namespace {

TEST(ReplayBackend, MakesReplayDevicesFromSpecs) {
  register_replay_device();
  // A 1 s recording at 100 Hz: the tool moves 10 mm along x.
  const auto file = std::filesystem::temp_directory_path() /
                    ("cariesim_factory_test_replay_" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(file);
  {
    SessionInfo info;
    info.scene = "friction-block";
    info.device = "scripted:line.csv";
    info.rate_hz = 100.0;
    Recorder recorder(file, info);
    recorder.start();
    for (int i = 0; i <= 100; ++i) {
      ServoSample s;
      s.t = 0.01 * i;
      s.haptic.p = Vec3(0.1 * i, 0, 1);
      s.graphic.p = Vec3(0.1 * i, 0, 1.5);
      ASSERT_TRUE(recorder.queue().push(s));
    }
    recorder.stop();
  }

  // The factory hands out a ReplayDevice (device/replay.hpp) over the recording, which plays the
  // recorded haptic poses.
  auto once = make_device("replay:" + file.string());
  EXPECT_EQ(once->info().name, "replay");
  auto* replay = dynamic_cast<ReplayDevice*>(once.get());
  ASSERT_NE(replay, nullptr);
  EXPECT_EQ(replay->size(), 101u);
  once->start();
  for (int wait = 0; !replay->ready(0.5) && wait < 10000; ++wait)  // the loader streams the file
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const DeviceState mid = once->read(0.5);
  EXPECT_TRUE(mid.valid);
  EXPECT_NEAR(mid.pose.p.x(), 5.0, 1e-9);
  EXPECT_NEAR(replay->recorded_graphic(0.5).p.z(), 1.5, 1e-9);
  EXPECT_FALSE(once->read(2.0).valid);  // past the end without looping

  // With ":loop" it starts over instead of ending.
  auto looped = make_device("replay:" + file.string() + ":loop");
  looped->start();
  // The file streams: wait (as replay_test does) until the loader has the second pass in.
  auto* looping = dynamic_cast<ReplayDevice*>(looped.get());
  ASSERT_NE(looping, nullptr);
  // The playback rule's period: 1 s, first to last sample (common/trajectory.hpp).
  for (int wait = 0; !looping->ready(1.0 + 0.5) && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const DeviceState again = looped->read(1.0 + 0.5);
  EXPECT_TRUE(again.valid);
  EXPECT_NEAR(again.pose.p.x(), 5.0, 1e-6);
  once.reset();
  looped.reset();
  std::filesystem::remove(file);
}

// A bad replay spec is named as the built-in ones are; registering twice is harmless.
TEST(ReplayBackend, BadSpecsNameTheSpec) {
  register_replay_device();
  register_replay_device();
  for (const std::string spec : {"replay", "replay:", "replay::loop", "replay:/no/such/recording.db"}) {
    try {
      (void)make_device(spec);
      ADD_FAILURE() << "no error for '" << spec << "'";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("device spec '" + spec + "': ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace cariesim
