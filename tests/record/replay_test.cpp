// The replay device: recorded haptic poses on the servo clock (exact at sample times, linear/slerp
// between them), velocities, buttons, the end of the recording, looping, the recorded graphic pose
// for the ghost tool, and no allocation in read().
#include "cariesim/record/replay.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
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

TEST(ReplayDevice, PlaysRecordedPosesAtSampleTimes) {
  const Recording recording = synthetic_recording();
  ReplayDevice device(recording);
  for (std::size_t i = 0; i < kCount; i += 7) {
    const double now = recording.samples[i].t;
    const DeviceState state = device.read(now);
    EXPECT_LT((state.pose.p - recording.samples[i].haptic.p).norm(), 1e-12) << i;
    EXPECT_LT(angle_between(state.pose.q, recording.samples[i].haptic.q), 1e-9) << i;
    EXPECT_EQ(state.buttons, recording.samples[i].buttons) << i;
    EXPECT_TRUE(state.valid);
    EXPECT_EQ(state.stamp, now);
  }
}

TEST(ReplayDevice, InterpolatesBetweenSamples) {
  const Recording recording = synthetic_recording();
  ReplayDevice device(recording);
  const std::size_t k = 123;
  const ServoSample& a = recording.samples[k];
  const ServoSample& b = recording.samples[k + 1];
  const double now = a.t + 0.25 / kRate;
  const DeviceState state = device.read(now);
  EXPECT_LT((state.pose.p - (0.75 * a.haptic.p + 0.25 * b.haptic.p)).norm(), 1e-12);
  // Slerp: a quarter of the way along the arc.
  const double full = angle_between(a.haptic.q, b.haptic.q);
  ASSERT_GT(full, 1e-6);
  EXPECT_NEAR(angle_between(a.haptic.q, state.pose.q), 0.25 * full, 1e-9);
  EXPECT_NEAR(angle_between(state.pose.q, b.haptic.q), 0.75 * full, 1e-9);
  EXPECT_NEAR(state.pose.q.norm(), 1.0, 1e-12);
  // The segment's velocity, mm/s and rad/s.
  EXPECT_LT((state.velocity - (b.haptic.p - a.haptic.p) * kRate).norm(), 1e-6);
  EXPECT_NEAR(state.angular_velocity.norm(), full * kRate, 1e-6);

  // The ghost: the recorded graphic pose, interpolated the same way; the other fields from sample k.
  const Pose ghost = device.recorded_graphic(now);
  EXPECT_LT((ghost.p - (0.75 * a.graphic.p + 0.25 * b.graphic.p)).norm(), 1e-12);
  const ServoSample recorded = device.recorded(now);
  EXPECT_EQ(recorded.state, a.state);
  EXPECT_EQ(recorded.force, a.force);
  EXPECT_DOUBLE_EQ(recorded.t, now);
}

TEST(ReplayDevice, TimeGoingBackwardsAndRecordingsNotStartingAtZero) {
  const Recording recording = synthetic_recording(5.0);
  ReplayDevice device(recording);
  EXPECT_DOUBLE_EQ(device.recording_time(0.0), 5.0);
  const DeviceState late = device.read(0.250);
  const DeviceState early = device.read(0.010);
  EXPECT_LT((late.pose.p - recording.samples[250].haptic.p).norm(), 1e-9);
  EXPECT_LT((early.pose.p - recording.samples[10].haptic.p).norm(), 1e-9);
  EXPECT_GT(early.sequence, late.sequence);
}

TEST(ReplayDevice, EndsOrLoops) {
  const Recording recording = synthetic_recording();
  const double end = recording.samples.back().t;
  ReplayDevice once(recording, false);
  const DeviceState after = once.read(end + 1.0);
  EXPECT_FALSE(after.valid) << "past the end the reading is invalid, so safety zeroes the force";
  EXPECT_TRUE(once.finished(end + 1.0));
  EXPECT_LT((after.pose.p - recording.samples.back().haptic.p).norm(), 1e-12) << "the last pose is held";

  ReplayDevice looping(recording, true);
  const double period = end;  // the playback rule's period: first to last sample
  for (const double now : {0.0105, 0.2}) {
    const DeviceState first = looping.read(now);
    const DeviceState again = looping.read(now + 2.0 * period);
    EXPECT_TRUE(again.valid);
    EXPECT_LT((first.pose.p - again.pose.p).norm(), 1e-9) << now;
  }
  EXPECT_FALSE(looping.finished(100.0));
  EXPECT_EQ(looping.info().name, "replay");
  EXPECT_FALSE(looping.info().renders_force);
}

TEST(ReplayDevice, ReadAllocatesNothing) {
  ReplayDevice device(synthetic_recording(), true);
  double sum = 0.0;
  const std::size_t before = test::allocation_count();
  for (int i = 0; i < 5000; ++i) sum += device.read(i * 1e-4).pose.p.x();
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sum));
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
  EXPECT_EQ(replay->session().scene, test::synthetic_session(kRate).scene);
  const ServoSample expected = test::synthetic_sample(42, kRate);
  // The loader thread streams the file: wait until the samples around the time are in.
  for (int wait = 0; !replay->ready(expected.t) && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  EXPECT_LT((device->read(expected.t).pose.p - expected.haptic.p).norm(), 1e-12);
  EXPECT_LT((replay->recorded_graphic(expected.t).p - expected.graphic.p).norm(), 1e-12);

  EXPECT_THROW(make_replay_device(dir / "absent.db"), Error);
  EXPECT_THROW(ReplayDevice(Recording{}), Error);
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
  ReplayDevice device(file, false);
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
  EXPECT_EQ(device.recorded(middle.t).state, middle.state);
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
  ReplayDevice looping(file, true);
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
  ReplayDevice memory(recording, true);
  ReplayDevice streamed(file, true);
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
  ReplayDevice again(recording, true);
  EXPECT_LT((again.read(now).pose.p - half.p).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(again.recording_time(now), 0.5 / kRate);
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
  ReplayDevice memory(recording);
  ReplayDevice streamed(file);
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
