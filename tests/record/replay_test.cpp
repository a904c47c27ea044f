// The record module's replay source: a recording, in memory or streamed from its file, played by the
// device module's ReplayDevice (its own tests: tests/device/replay_test.cpp): the recorded poses at
// sample times, the whole recorded sample at any time (recorded()), the session row, a long file
// streamed with bounded memory, looping from the file, and the same playback as the scripted device.
#include "cariesim/record/replay.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "record/record_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

constexpr double kRate = 1000.0;  // Hz
constexpr std::size_t kCount = 300;

Recording synthetic_recording(double first_t = 0.0) {
  Recording r;
  r.info = test::synthetic_session(kRate);
  for (std::size_t i = 0; i < kCount; ++i) {
    ServoSample s = test::synthetic_sample(i, kRate);
    s.t += first_t;
    r.samples.push_back(s);
  }
  return r;
}

double angle_between(const Quat& a, const Quat& b) { return a.angularDistance(b); }

// The whole recorded sample at a time between two samples: both poses interpolated (as read() and
// recorded_graphic() play them), every other field from the sample at or before it.
TEST(ReplaySource, RecordedSampleBetweenSamples) {
  const Recording recording = synthetic_recording();
  const auto device = make_replay_device(recording);
  const std::size_t k = 123;
  const ServoSample& a = recording.samples[k];
  const ServoSample& b = recording.samples[k + 1];
  const double now = a.t + 0.25 / kRate;
  const DeviceState state = device->read(now);
  EXPECT_LT((state.pose.p - (0.75 * a.haptic.p + 0.25 * b.haptic.p)).norm(), 1e-12);
  const ServoSample sample = recorded(*device, now);
  EXPECT_EQ(sample.haptic.p, state.pose.p);
  EXPECT_EQ(sample.graphic.p, device->recorded_graphic(now).p);
  EXPECT_LT((sample.graphic.p - (0.75 * a.graphic.p + 0.25 * b.graphic.p)).norm(), 1e-12);
  EXPECT_EQ(sample.state, a.state);
  EXPECT_EQ(sample.force, a.force);
  EXPECT_EQ(sample.buttons, a.buttons);
  EXPECT_DOUBLE_EQ(sample.t, now);
  EXPECT_EQ(replayed_recording(*device)->session().scene, recording.info.scene);
  EXPECT_EQ(device->size(), kCount);
}

// A recording's samples that cannot be played in order (a time not finite or not after the one
// before) are left out of the source, so recorded() never returns one.
TEST(ReplaySource, LeavesOutSamplesThatCannotBePlayedInOrder) {
  Recording recording = synthetic_recording();
  recording.samples[10].t = std::numeric_limits<double>::quiet_NaN();
  recording.samples[20].t = recording.samples[19].t;
  recording.samples[20].state = InteractionState::Extracting;
  recording.samples[19].state = InteractionState::Free;
  const auto device = make_replay_device(recording);
  EXPECT_EQ(device->size(), kCount - 2);
  EXPECT_EQ(recorded(*device, recording.samples[19].t).state, InteractionState::Free);
  EXPECT_TRUE(std::isfinite(recorded(*device, recording.samples[10].t).t));
}

// The servo thread's read() of a replayed recording allocates nothing.
TEST(ReplaySource, ReadAllocatesNothing) {
  const auto device = make_replay_device(synthetic_recording(), true);
  double sum = 0.0;
  const std::size_t before = test::allocation_count();
  for (int i = 0; i < 5000; ++i) sum += device->read(i * 1e-4).pose.p.x();
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sum));
}

// Only a device that plays a recording has one.
TEST(ReplaySource, OtherDevicesPlayNoRecording) {
  const NullDevice null(Pose{});
  EXPECT_EQ(replayed_recording(null), nullptr);
}

TEST(ReplayDevice, FromARecordedFile) {
  test::ScratchDir dir("replay_file");
  const auto file = dir / "session.db";
  {
    Recorder recorder(file, test::synthetic_session(kRate));
    for (std::size_t i = 0; i < kCount; ++i)
      ASSERT_TRUE(recorder.queue().push(test::synthetic_sample(i, kRate)));
    recorder.stop();
  }
  const std::unique_ptr<Device> device = make_replay_device(file, false);
  auto* replay = dynamic_cast<ReplayDevice*>(device.get());
  ASSERT_NE(replay, nullptr);
  EXPECT_EQ(replay->size(), kCount);
  ASSERT_NE(replayed_recording(*device), nullptr);
  EXPECT_EQ(replayed_recording(*device)->session().scene, test::synthetic_session(kRate).scene);
  const ServoSample expected = test::synthetic_sample(42, kRate);
  // The loader thread streams the file: wait until the samples around the time are in.
  for (int wait = 0; !replay->ready(expected.t) && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  EXPECT_LT((device->read(expected.t).pose.p - expected.haptic.p).norm(), 1e-12);
  EXPECT_LT((replay->recorded_graphic(expected.t).p - expected.graphic.p).norm(), 1e-12);

  EXPECT_THROW(make_replay_device(dir / "absent.db"), Error);
  EXPECT_THROW((void)make_replay_device(Recording{}), Error);
}

// A file is streamed: the device holds at most kReplayReadAhead samples however long the recording
// (here three buffers and more), and plays every recorded pose at its sample time, in order.
TEST(ReplayDevice, StreamsAFileWithBoundedMemory) {
  test::ScratchDir dir("replay_stream");
  const auto file = dir / "long.db";
  constexpr double kFast = 4000.0;  // Hz
  const std::size_t count = 3 * kReplayReadAhead + 123;
  {
    RecorderOptions options;
    options.queue_capacity = count;
    Recorder recorder(file, test::synthetic_session(kFast), options);
    for (std::size_t i = 0; i < count; ++i)
      ASSERT_TRUE(recorder.queue().push(test::synthetic_sample(i, kFast)));
    recorder.start();
    recorder.stop();
  }
  const auto streamed = make_replay_device(file, false);
  ReplayDevice& device = *streamed;
  EXPECT_EQ(device.size(), count);
  EXPECT_LE(device.buffered_samples(), kReplayReadAhead);
  for (std::size_t i = 0; i < count; ++i) {
    const ServoSample expected = test::synthetic_sample(i, kFast);
    // The loader runs ahead on its own thread; this loop plays faster than real time, so it waits
    // for the samples as a real-time servo thread never has to.
    for (int wait = 0; !device.ready(expected.t) && wait < 10000; ++wait)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    const DeviceState state = device.read(expected.t);
    ASSERT_LT((state.pose.p - expected.haptic.p).norm(), 1e-12) << i;
    ASSERT_LT(angle_between(state.pose.q, expected.haptic.q), 1e-9) << i;
    ASSERT_EQ(state.buttons, expected.buttons) << i;
  }
  EXPECT_LE(device.max_buffered_samples(), kReplayReadAhead) << "bounded, whatever the recording's length";
  EXPECT_LT(device.max_buffered_samples(), count);
  EXPECT_FALSE(device.read(test::synthetic_sample(count - 1, kFast).t + 1.0).valid) << "the end";
  // The look-up (the ghost tool's) reads the file at any time.
  const ServoSample middle = test::synthetic_sample(count / 2, kFast);
  EXPECT_LT((device.recorded_graphic(middle.t).p - middle.graphic.p).norm(), 1e-12);
  EXPECT_EQ(recorded(device, middle.t).state, middle.state);
}

// A looping file starts again at its last sample's time, as an in-memory recording does.
TEST(ReplayDevice, AStreamedFileLoops) {
  test::ScratchDir dir("replay_stream_loop");
  const auto file = dir / "loop.db";
  {
    Recorder recorder(file, test::synthetic_session(kRate));
    for (std::size_t i = 0; i < kCount; ++i)
      ASSERT_TRUE(recorder.queue().push(test::synthetic_sample(i, kRate)));
    recorder.start();
    recorder.stop();
  }
  const auto device = make_replay_device(file, true);
  ReplayDevice& looping = *device;
  const double period = test::synthetic_sample(kCount - 1, kRate).t;
  for (int cycle = 0; cycle < 3; ++cycle) {
    for (std::size_t i = 0; i < kCount; i += 11) {
      const double now = cycle * period + test::synthetic_sample(i, kRate).t;
      for (int wait = 0; !looping.ready(now) && wait < 10000; ++wait)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
      const DeviceState state = looping.read(now);
      EXPECT_TRUE(state.valid);
      ASSERT_LT((state.pose.p - test::synthetic_sample(i, kRate).haptic.p).norm(), 1e-9) << cycle << " " << i;
    }
  }
}

// One playback for every device: the replay device plays a recording's haptic poses exactly as the
// scripted device plays the same poses as a trajectory, looping included (the period is the
// duration, first to last sample, not one sample interval more), in memory and from a file.
TEST(ReplayDevice, PlaysAsTheScriptedDeviceDoes) {
  test::ScratchDir dir("replay_as_scripted");
  const auto file = dir / "loop.db";
  const Recording recording = synthetic_recording();
  Trajectory trajectory;
  for (const ServoSample& s : recording.samples) trajectory.add(s.t, s.haptic);
  {
    Recorder recorder(file, recording.info);
    for (const ServoSample& s : recording.samples) ASSERT_TRUE(recorder.queue().push(s));
    recorder.start();
    recorder.stop();
  }
  ScriptedDevice scripted(trajectory, true, "the recording's poses");
  const auto from_memory = make_replay_device(recording, true);
  const auto from_file = make_replay_device(file, true);
  ReplayDevice& memory = *from_memory;
  ReplayDevice& streamed = *from_file;
  const double duration = trajectory.end() - trajectory.start();
  scripted.start();
  for (double now = 0.0; now < 2.5 * duration; now += 0.37 / kRate) {
    const Pose expected = scripted.read(now).pose;
    const Pose played = memory.read(now).pose;
    EXPECT_EQ(played.p, expected.p) << now;
    EXPECT_EQ(played.q.coeffs(), expected.q.coeffs()) << now;
    for (int wait = 0; !streamed.ready(now) && wait < 10000; ++wait)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    const Pose from_file = streamed.read(now).pose;
    ASSERT_LT((from_file.p - expected.p).norm(), 1e-9) << now;
    ASSERT_LT(angle_between(from_file.q, expected.q), 1e-9) << now;
  }
  // Half a sample interval into the second loop: half-way between the first two samples (on main the
  // replay held the last sample for one more interval).
  const double now = duration + 0.5 / kRate;
  const Pose half = blend(recording.samples[0].haptic, recording.samples[1].haptic, 0.5);
  const auto again = make_replay_device(recording, true);
  EXPECT_LT((again->read(now).pose.p - half.p).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(again->recording_time(now), 0.5 / kRate);
}

// A recording made elsewhere may hold quaternions a little off unit length (within the input guard's
// kUnitTolerance): the played pose is a unit quaternion between them, not their unnormalised slerp.
TEST(ReplayDevice, BlendsToAUnitQuaternion) {
  test::ScratchDir dir("replay_unit");
  const auto file = dir / "long_quaternions.db";
  Recording recording = synthetic_recording();
  for (ServoSample& s : recording.samples) {
    s.haptic.q.coeffs() *= 1.0008;
    s.graphic.q.coeffs() *= 1.0008;
  }
  {
    Recorder recorder(file, recording.info);
    for (const ServoSample& s : recording.samples) ASSERT_TRUE(recorder.queue().push(s));
    recorder.start();
    recorder.stop();
  }
  const auto from_memory = make_replay_device(recording);
  const auto from_file = make_replay_device(file);
  ReplayDevice& memory = *from_memory;
  ReplayDevice& streamed = *from_file;
  for (std::size_t k : {10u, 123u, 250u}) {
    const double now = recording.samples[k].t + 0.4 / kRate;
    EXPECT_NEAR(memory.read(now).pose.q.norm(), 1.0, 1e-12) << k;
    EXPECT_NEAR(memory.recorded_graphic(now).q.norm(), 1.0, 1e-12) << k;
    for (int wait = 0; !streamed.ready(now) && wait < 10000; ++wait)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    EXPECT_NEAR(streamed.read(now).pose.q.norm(), 1.0, 1e-12) << k;
    EXPECT_NEAR(streamed.recorded_graphic(now).q.norm(), 1.0, 1e-12) << k;
  }
}

}  // namespace
}  // namespace cariesim
