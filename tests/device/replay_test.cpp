// The replay device (device/replay.hpp) over a source made here: recorded haptic poses on the servo
// clock (exact at frame times, linear/slerp between them), velocities, buttons, the end, looping, the
// recorded graphic pose for the ghost tool, frames that cannot be played skipped, the streamed
// read-ahead ring (bounded, underruns counted, the source's failure reported), and no allocation in
// read(). The record module's source over a recording file is tested in tests/record/replay_test.cpp.
#include "cariesim/device/replay.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

constexpr double kRate = 1000.0;  // Hz
constexpr std::size_t kCount = 300;

// Frame i of a synthetic recording at `rate_hz`: the tool circling and turning, the ghost beside it,
// the buttons changing every 100 frames.
ReplayFrame synthetic_frame(std::size_t i, double rate_hz = kRate, double first_t = 0.0) {
  const double phase = static_cast<double>(i) * 0.01;
  ReplayFrame f;
  f.t = first_t + static_cast<double>(i) / rate_hz;
  f.haptic.p = Vec3(10.0 * std::cos(phase), 10.0 * std::sin(phase), 0.001 * static_cast<double>(i));
  f.haptic.q = Quat(Eigen::AngleAxisd(0.3 * std::sin(phase), Vec3(1, 2, 3).normalized()));
  f.graphic.p = f.haptic.p + Vec3(0.01, -0.02, 0.5 * std::sin(phase));
  f.graphic.q = Quat(Eigen::AngleAxisd(0.2 * std::cos(phase), Vec3(0, 1, 0)));
  f.buttons = static_cast<uint32_t>((i / 100) % 4);
  return f;
}

std::vector<ReplayFrame> synthetic_frames(std::size_t count = kCount, double rate_hz = kRate,
                                          double first_t = 0.0) {
  std::vector<ReplayFrame> frames;
  for (std::size_t i = 0; i < count; ++i) frames.push_back(synthetic_frame(i, rate_hz, first_t));
  return frames;
}

// What a source may be told to do to the device: stall after its first batch until released, or
// fail after a number of batches.
struct SourceControl {
  std::atomic<bool> stall{false};
  std::atomic<bool> released{false};
  std::size_t fail_after = std::numeric_limits<std::size_t>::max();  // batches
  std::atomic<std::size_t> batches{0};
};

// Frames held here, handed out in memory or streamed in batches; the look-up blends the frames
// around the time as the device's contract asks. Allocates nothing after construction.
class FramesSource : public ReplaySource {
 public:
  FramesSource(std::vector<ReplayFrame> frames, bool in_memory, SourceControl* control = nullptr)
      : frames_(std::move(frames)), in_memory_(in_memory), control_(control) {
    for (const ReplayFrame& f : frames_) {
      if (!std::isfinite(f.t)) continue;
      first_t_ = std::min(first_t_, f.t);
      last_t_ = std::isfinite(last_t_) ? std::max(last_t_, f.t) : f.t;
    }
  }
  [[nodiscard]] std::string description() const override { return "test frames"; }
  [[nodiscard]] std::size_t size() const override { return frames_.size(); }
  [[nodiscard]] double first_t() const override { return first_t_; }
  [[nodiscard]] double last_t() const override { return last_t_; }
  [[nodiscard]] bool in_memory() const override { return in_memory_; }
  std::size_t read(std::span<ReplayFrame> out) override {
    if (control_ != nullptr) {
      const std::size_t batch = control_->batches.fetch_add(1);
      if (batch >= control_->fail_after) throw Error("test frames: the source broke");
      while (batch > 0 && control_->stall.load() && !control_->released.load())
        std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    const std::size_t n = std::min(out.size(), frames_.size() - next_);
    std::copy_n(frames_.begin() + static_cast<std::ptrdiff_t>(next_), n, out.begin());
    next_ += n;
    return n;
  }
  void rewind() override { next_ = 0; }
  [[nodiscard]] ReplayFrame frame_at(double t) const override {
    std::size_t k = 0;
    while (k + 1 < frames_.size() && frames_[k + 1].t <= t) ++k;
    ReplayFrame out = frames_[k];
    if (k + 1 < frames_.size() && t > out.t) {
      const double u = (t - out.t) / (frames_[k + 1].t - out.t);
      out.haptic = blend(out.haptic, frames_[k + 1].haptic, u);
      out.graphic = blend(out.graphic, frames_[k + 1].graphic, u);
      out.t = t;
    }
    return out;
  }

 private:
  std::vector<ReplayFrame> frames_;
  bool in_memory_;
  SourceControl* control_;
  std::size_t next_ = 0;
  double first_t_ = std::numeric_limits<double>::infinity();
  double last_t_ = std::numeric_limits<double>::quiet_NaN();
};

ReplayDevice in_memory(std::vector<ReplayFrame> frames, bool loop = false) {
  return ReplayDevice(std::make_unique<FramesSource>(std::move(frames), true), loop);
}

std::unique_ptr<ReplayDevice> streamed(std::vector<ReplayFrame> frames, bool loop = false,
                                       SourceControl* control = nullptr) {
  return std::make_unique<ReplayDevice>(std::make_unique<FramesSource>(std::move(frames), false, control),
                                        loop);
}

// Waits (as a real-time servo thread never has to) until the loader has the frames around `now`.
void wait_ready(const ReplayDevice& device, double now) {
  for (int wait = 0; !device.ready(now) && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
}

double angle_between(const Quat& a, const Quat& b) { return a.angularDistance(b); }

TEST(ReplayDevice, PlaysRecordedPosesAtFrameTimes) {
  const std::vector<ReplayFrame> frames = synthetic_frames();
  ReplayDevice memory = in_memory(frames);
  const auto stream = streamed(frames);
  for (std::size_t i = 0; i < kCount; i += 7) {
    const double now = frames[i].t;
    wait_ready(*stream, now);
    for (ReplayDevice* device : {&memory, stream.get()}) {
      const DeviceState state = device->read(now);
      EXPECT_LT((state.pose.p - frames[i].haptic.p).norm(), 1e-12) << i;
      EXPECT_LT(angle_between(state.pose.q, frames[i].haptic.q), 1e-9) << i;
      EXPECT_EQ(state.buttons, frames[i].buttons) << i;
      EXPECT_TRUE(state.valid);
      EXPECT_EQ(state.stamp, now);
    }
  }
  EXPECT_EQ(memory.size(), kCount);
  EXPECT_EQ(stream->size(), kCount);
  EXPECT_EQ(memory.info().name, "replay");
  EXPECT_FALSE(memory.info().renders_force);
  EXPECT_NE(stream->info().description.find("test frames (300 samples, 0.299 s)"), std::string::npos)
      << stream->info().description;
}

TEST(ReplayDevice, InterpolatesBetweenFrames) {
  const std::vector<ReplayFrame> frames = synthetic_frames();
  ReplayDevice memory = in_memory(frames);
  const auto stream = streamed(frames);
  const std::size_t k = 123;
  const ReplayFrame& a = frames[k];
  const ReplayFrame& b = frames[k + 1];
  const double now = a.t + 0.25 / kRate;
  wait_ready(*stream, now);
  for (ReplayDevice* device : {&memory, stream.get()}) {
    const DeviceState state = device->read(now);
    EXPECT_LT((state.pose.p - (0.75 * a.haptic.p + 0.25 * b.haptic.p)).norm(), 1e-12);
    // Slerp: a quarter of the way along the arc.
    const double full = angle_between(a.haptic.q, b.haptic.q);
    ASSERT_GT(full, 1e-6);
    EXPECT_NEAR(angle_between(a.haptic.q, state.pose.q), 0.25 * full, 1e-9);
    EXPECT_NEAR(angle_between(state.pose.q, b.haptic.q), 0.75 * full, 1e-9);
    EXPECT_NEAR(state.pose.q.norm(), 1.0, 1e-12);
    // The segment's velocity, mm/s and rad/s; the buttons of frame k.
    EXPECT_LT((state.velocity - (b.haptic.p - a.haptic.p) * kRate).norm(), 1e-6);
    EXPECT_NEAR(state.angular_velocity.norm(), full * kRate, 1e-6);
    EXPECT_EQ(state.buttons, a.buttons);
    // The ghost: the recorded graphic pose, interpolated the same way.
    const Pose ghost = device->recorded_graphic(now);
    EXPECT_LT((ghost.p - (0.75 * a.graphic.p + 0.25 * b.graphic.p)).norm(), 1e-12);
  }
}

TEST(ReplayDevice, InMemoryPlaysAnyTimeInAnyOrderFromTheFirstFrame) {
  const std::vector<ReplayFrame> frames = synthetic_frames(kCount, kRate, 5.0);
  ReplayDevice device = in_memory(frames);
  EXPECT_DOUBLE_EQ(device.recording_time(0.0), 5.0);
  const DeviceState late = device.read(0.250);
  const DeviceState early = device.read(0.010);
  EXPECT_LT((late.pose.p - frames[250].haptic.p).norm(), 1e-9);
  EXPECT_LT((early.pose.p - frames[10].haptic.p).norm(), 1e-9);
  EXPECT_GT(early.sequence, late.sequence);
}

// A streamed source is played as servo time goes, forward: an earlier time holds the current pose.
TEST(ReplayDevice, StreamedTimeOnlyGoesForward) {
  const std::vector<ReplayFrame> frames = synthetic_frames();
  const auto device = streamed(frames);
  wait_ready(*device, 0.250);
  const DeviceState late = device->read(0.250);
  const DeviceState early = device->read(0.010);
  EXPECT_LT((late.pose.p - frames[250].haptic.p).norm(), 1e-9);
  EXPECT_LT((early.pose.p - frames[250].haptic.p).norm(), 1e-9);
}

TEST(ReplayDevice, EndsOrLoops) {
  const std::vector<ReplayFrame> frames = synthetic_frames();
  const double end = frames.back().t;
  const double period = end;  // the playback rule's period: first to last frame
  ReplayDevice memory_once = in_memory(frames, false);
  ReplayDevice memory_looping = in_memory(frames, true);
  const auto stream_once = streamed(frames, false);
  for (ReplayDevice* once : {&memory_once, stream_once.get()}) {
    wait_ready(*once, end + 1.0);
    const DeviceState after = once->read(end + 1.0);
    EXPECT_FALSE(after.valid) << "past the end the reading is invalid, so safety zeroes the force";
    EXPECT_TRUE(once->finished(end + 1.0));
    EXPECT_LT((after.pose.p - frames.back().haptic.p).norm(), 1e-12) << "the last pose is held";
  }
  const auto stream_looping = streamed(frames, true);
  for (int cycle = 0; cycle < 3; ++cycle) {
    for (std::size_t i = 0; i < kCount; i += 11) {
      const double now = cycle * period + frames[i].t + 0.3 / kRate;
      wait_ready(*stream_looping, now);
      const DeviceState from_stream = stream_looping->read(now);
      const DeviceState from_memory = memory_looping.read(now);
      const DeviceState first_cycle = memory_looping.read(now - cycle * period);
      for (const DeviceState& state : {from_stream, from_memory}) {
        EXPECT_TRUE(state.valid);
        ASSERT_LT((state.pose.p - first_cycle.pose.p).norm(), 1e-9) << cycle << " " << i;
      }
    }
  }
  EXPECT_FALSE(memory_looping.finished(100.0));
}

TEST(ReplayDevice, ReadAllocatesNothing) {
  ReplayDevice memory = in_memory(synthetic_frames(), true);
  const auto stream = streamed(synthetic_frames(3 * kReplayReadAhead, 4000.0), true);
  double sum = 0.0;
  const std::size_t before = test::allocation_count();
  for (int i = 0; i < 5000; ++i) sum += memory.read(i * 1e-4).pose.p.x();
  // The streamed read, with the loader running beside it (its ring and batch allocated before).
  for (int i = 0; i < 20000; ++i) sum += stream->read(i * 2.5e-4).pose.p.x();
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sum));
}

// A streamed source: the device holds at most kReplayReadAhead frames however long the recording
// (here three rings and more), and plays every recorded pose at its frame time, in order.
TEST(ReplayDevice, StreamsWithBoundedMemory) {
  constexpr double kFast = 4000.0;  // Hz
  const std::size_t count = 3 * kReplayReadAhead + 123;
  const std::vector<ReplayFrame> frames = synthetic_frames(count, kFast);
  const auto device = streamed(frames);
  EXPECT_EQ(device->size(), count);
  EXPECT_LE(device->buffered_samples(), kReplayReadAhead);
  for (std::size_t i = 0; i < count; ++i) {
    wait_ready(*device, frames[i].t);
    const DeviceState state = device->read(frames[i].t);
    ASSERT_LT((state.pose.p - frames[i].haptic.p).norm(), 1e-12) << i;
    ASSERT_LT(angle_between(state.pose.q, frames[i].haptic.q), 1e-9) << i;
    ASSERT_EQ(state.buttons, frames[i].buttons) << i;
  }
  EXPECT_LE(device->max_buffered_samples(), kReplayReadAhead) << "bounded, whatever the recording's length";
  EXPECT_LT(device->max_buffered_samples(), count);
  EXPECT_FALSE(device->read(frames.back().t + 1.0).valid) << "the end";
  EXPECT_EQ(device->underruns(), 0u);
  // The look-up (the ghost tool's) asks the source at any time.
  EXPECT_LT((device->recorded_graphic(frames[count / 2].t).p - frames[count / 2].graphic.p).norm(), 1e-12);
}

// One playback for every device: the replay device plays the frames' haptic poses exactly as the
// scripted device plays the same poses as a trajectory, looping included (the period is the
// duration, first to last frame, not one frame interval more), in memory and streamed.
TEST(ReplayDevice, PlaysAsTheScriptedDeviceDoes) {
  const std::vector<ReplayFrame> frames = synthetic_frames();
  Trajectory trajectory;
  for (const ReplayFrame& f : frames) trajectory.add(f.t, f.haptic);
  ScriptedDevice scripted(trajectory, true, "the recording's poses");
  ReplayDevice memory = in_memory(frames, true);
  const auto stream = streamed(frames, true);
  const double duration = trajectory.end() - trajectory.start();
  scripted.start();
  for (double now = 0.0; now < 2.5 * duration; now += 0.37 / kRate) {
    const Pose expected = scripted.read(now).pose;
    const Pose played = memory.read(now).pose;
    EXPECT_EQ(played.p, expected.p) << now;
    EXPECT_EQ(played.q.coeffs(), expected.q.coeffs()) << now;
    wait_ready(*stream, now);
    const Pose from_stream = stream->read(now).pose;
    ASSERT_LT((from_stream.p - expected.p).norm(), 1e-9) << now;
    ASSERT_LT(angle_between(from_stream.q, expected.q), 1e-9) << now;
  }
  // Half a frame interval into the second loop: half-way between the first two frames.
  const double now = duration + 0.5 / kRate;
  const Pose half = blend(frames[0].haptic, frames[1].haptic, 0.5);
  ReplayDevice again = in_memory(frames, true);
  EXPECT_LT((again.read(now).pose.p - half.p).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(again.recording_time(now), 0.5 / kRate);
}

// Frames recorded elsewhere may hold quaternions a little off unit length (within the input guard's
// kUnitTolerance): the played pose is a unit quaternion between them, not their unnormalised slerp.
TEST(ReplayDevice, BlendsToAUnitQuaternion) {
  std::vector<ReplayFrame> frames = synthetic_frames();
  for (ReplayFrame& f : frames) {
    f.haptic.q.coeffs() *= 1.0008;
    f.graphic.q.coeffs() *= 1.0008;
  }
  ReplayDevice memory = in_memory(frames);
  const auto stream = streamed(frames);
  for (std::size_t k : {10u, 123u, 250u}) {
    const double now = frames[k].t + 0.4 / kRate;
    EXPECT_NEAR(memory.read(now).pose.q.norm(), 1.0, 1e-12) << k;
    EXPECT_NEAR(memory.recorded_graphic(now).q.norm(), 1.0, 1e-12) << k;
    wait_ready(*stream, now);
    EXPECT_NEAR(stream->read(now).pose.q.norm(), 1.0, 1e-12) << k;
  }
}

// Frames whose time is not finite or not after the one before cannot be played in order: both ways
// of playing skip them.
TEST(ReplayDevice, SkipsFramesThatCannotBePlayedInOrder) {
  std::vector<ReplayFrame> frames = synthetic_frames(10);
  std::vector<ReplayFrame> hostile = frames;
  hostile[3].t = std::numeric_limits<double>::quiet_NaN();
  hostile[5].t = hostile[4].t;  // not after the one before
  hostile[7].t = -1.0;          // back in time
  hostile[7].haptic.p = Vec3(1e6, 0, 0);
  ReplayDevice memory = in_memory(hostile);
  const auto stream = streamed(hostile);
  EXPECT_EQ(memory.size(), 7u) << "the playable frames";
  for (double now = 0.0; now <= frames.back().t; now += 0.25 / kRate) {
    wait_ready(*stream, now);
    for (ReplayDevice* device : {&memory, stream.get()}) {
      const DeviceState state = device->read(now);
      ASSERT_TRUE(state.pose.p.allFinite()) << now;
      ASSERT_LT(state.pose.p.norm(), 11.0) << now << ": the hostile frame is never played";
    }
  }
}

TEST(ReplayDevice, ASourceWithNothingToPlayOrThatFailsIsAnError) {
  const auto message_of = [](const auto& make) -> std::string {
    try {
      make();
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  };
  std::vector<ReplayFrame> nan_times = synthetic_frames(5);
  for (ReplayFrame& f : nan_times) f.t = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(message_of([] { (void)in_memory({}); }), "test frames: the recording holds no samples to replay");
  EXPECT_NE(
      message_of([&] { (void)in_memory(nan_times); }).find("test frames: the recording holds no samples"),
      std::string::npos);
  EXPECT_NE(
      message_of([&] { (void)streamed(nan_times); }).find("test frames: the recording holds no samples"),
      std::string::npos);
  EXPECT_THROW(ReplayDevice(nullptr), Error);
  // The loader's first batch fails: the constructor says why.
  SourceControl control;
  control.fail_after = 0;
  EXPECT_EQ(message_of([&] { (void)streamed(synthetic_frames(), false, &control); }),
            "test frames: the source broke");
}

// The loader falls behind (its source stalls after the first batch): read() holds the last loaded
// pose, valid, and counts each such cycle; once the source goes on, the frames play again.
TEST(ReplayDevice, CountsUnderrunsWhenTheLoaderFallsBehind) {
  constexpr double kFast = 4000.0;  // Hz
  const std::vector<ReplayFrame> frames = synthetic_frames(3 * kReplayBatch, kFast);
  SourceControl control;
  control.stall = true;
  const auto device = streamed(frames, false, &control);
  // Released before the device goes (it joins its loader), whatever fails below.
  const struct Release {
    SourceControl& control;
    ~Release() { control.released = true; }
  } release{control};
  // The loader pushed its whole first batch once it asks for the second.
  for (int wait = 0; control.batches.load() < 2 && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  ASSERT_EQ(device->buffered_samples(), kReplayBatch);
  const double late = frames[2 * kReplayBatch].t;
  EXPECT_FALSE(device->ready(late));
  for (int i = 0; i < 10; ++i) {
    const DeviceState held = device->read(late);
    EXPECT_TRUE(held.valid);
    EXPECT_LT((held.pose.p - frames[kReplayBatch - 1].haptic.p).norm(), 1e-12) << "the last loaded pose";
  }
  EXPECT_EQ(device->underruns(), 10u);
  control.released = true;
  wait_ready(*device, late);
  EXPECT_LT((device->read(late).pose.p - frames[2 * kReplayBatch].haptic.p).norm(), 1e-12);
  EXPECT_EQ(device->underruns(), 10u);
}

}  // namespace
}  // namespace cariesim
