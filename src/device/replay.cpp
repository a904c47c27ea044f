#include "cariesim/device/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

// The loader's sleep when the read-ahead ring is full.
constexpr auto kLoaderIdle = std::chrono::milliseconds(1);

}  // namespace

// A streamed source: the loader thread and the read-ahead ring (written by the loader, read by the
// servo thread, lock-free: `head` entries written, `tail` the servo's current entry, so the loader
// writes only slots below tail + capacity).
struct ReplayDevice::Stream {
  struct Entry {
    double play = 0.0;  // s of servo time at which it plays (a loop's seam: the next loop's first
                        // entry plays at its last entry's time)
    ReplayFrame frame;
  };
  // The loaded entries [tail, head) as a PlaybackCursor source (common/trajectory.hpp).
  struct Loaded {
    const Stream* stream;
    std::uint64_t from, to;
    [[nodiscard]] std::uint64_t first() const { return from; }
    [[nodiscard]] std::uint64_t end() const { return to; }
    [[nodiscard]] const Entry& entry(std::uint64_t i) const { return stream->ring[i % stream->ring.size()]; }
    [[nodiscard]] double time(std::uint64_t i) const { return entry(i).play; }
    [[nodiscard]] const Pose& pose(std::uint64_t i) const { return entry(i).frame.haptic; }
  };

  ~Stream() {
    stop.store(true);
    if (loader.joinable()) loader.join();
  }
  void run();
  [[nodiscard]] std::size_t held() const {
    return static_cast<std::size_t>(head.load(std::memory_order_acquire) -
                                    tail.load(std::memory_order_acquire));
  }

  ReplaySource* source = nullptr;  // the device's; read by the loader only once it runs
  double first_t = 0.0, last_t = 0.0, period = 0.0;
  bool loop = false;
  std::vector<Entry> ring;         // kReplayReadAhead entries, allocated once
  std::vector<ReplayFrame> batch;  // the loader's: kReplayBatch frames, allocated once
  alignas(64) std::atomic<std::uint64_t> head{0};
  alignas(64) std::atomic<std::uint64_t> tail{0};
  std::atomic<std::size_t> max_held{0};
  std::atomic<std::uint64_t> underruns{0};
  std::atomic<bool> ended{false};
  std::atomic<bool> failed{false};
  std::string failure;  // written before `failed` is set
  std::atomic<bool> stop{false};
  std::uint64_t cursor = 0;         // servo thread: the entry at or before the played time
  PlaybackCursor<Loaded> playback;  // servo thread
  std::thread loader;               // last: started when everything above is in place, joined first
};

// The loader: a batch of frames whenever the ring has room for one, those whose time is finite,
// increasing and within the played range, each with its play time; the start again when looping.
void ReplayDevice::Stream::run() {
  try {
    std::uint64_t cycle = 0;
    std::uint64_t pushed_this_cycle = 0;
    double last = -std::numeric_limits<double>::infinity();
    const std::uint64_t capacity = ring.size();
    while (!stop.load(std::memory_order_relaxed)) {
      std::uint64_t w = head.load(std::memory_order_relaxed);
      if (w - tail.load(std::memory_order_acquire) + kReplayBatch > capacity) {
        std::this_thread::sleep_for(kLoaderIdle);
        continue;
      }
      const std::size_t rows = source->read(std::span<ReplayFrame>(batch));
      for (std::size_t i = 0; i < rows; ++i) {
        const ReplayFrame& f = batch[i];
        if (!std::isfinite(f.t) || !(f.t > last) || f.t > last_t) continue;
        last = f.t;
        Entry& e = ring[w % capacity];
        e.play = f.t - first_t + static_cast<double>(cycle) * period;
        e.frame = f;
        ++pushed_this_cycle;
        head.store(++w, std::memory_order_release);
        const auto now_held = static_cast<std::size_t>(w - tail.load(std::memory_order_acquire));
        if (now_held > max_held.load(std::memory_order_relaxed))
          max_held.store(now_held, std::memory_order_relaxed);
      }
      if (rows > 0) continue;
      // The end: again from the start when looping (a cycle that played nothing, or a recording of
      // no duration, whose one pose is held, ends it too).
      if (!loop || pushed_this_cycle == 0 || !(period > 0.0)) break;
      ++cycle;
      pushed_this_cycle = 0;
      source->rewind();
      last = -std::numeric_limits<double>::infinity();
    }
  } catch (const std::exception& e) {
    failure = e.what();
    failed.store(true, std::memory_order_release);
  }
  ended.store(true, std::memory_order_release);
}

// In memory: every frame read at once, those whose time is finite and increasing kept (anything else
// could not be played in order). Streamed: the ring, then the loader; its first batch.
ReplayDevice::ReplayDevice(std::unique_ptr<ReplaySource> source, bool loop)
    : source_(std::move(source)), loop_(loop) {
  if (!source_) throw Error("replay device: no source");
  if (source_->in_memory()) {
    frames_.reserve(source_->size());
    std::vector<ReplayFrame> batch(kReplayBatch);
    while (const std::size_t rows = source_->read(std::span<ReplayFrame>(batch))) {
      for (std::size_t i = 0; i < rows; ++i) {
        const ReplayFrame& f = batch[i];
        if (!std::isfinite(f.t) || (!frames_.empty() && !(f.t > frames_.back().t))) continue;
        frames_.push_back(f);
      }
    }
    if (frames_.empty()) throw Error(source_->description() + ": the recording holds no samples to replay");
    first_t_ = frames_.front().t;
    last_t_ = frames_.back().t;
    rows_ = frames_.size();
    return;
  }

  first_t_ = source_->first_t();
  last_t_ = source_->last_t();
  if (!std::isfinite(first_t_) || !std::isfinite(last_t_) || last_t_ < first_t_)
    throw Error(source_->description() +
                ": the recording holds no samples to replay (no increasing finite times)");
  rows_ = source_->size();
  stream_ = std::make_unique<Stream>();
  Stream& s = *stream_;
  s.source = source_.get();
  s.first_t = first_t_;
  s.last_t = last_t_;
  s.period = duration();  // the playback rule's period (common/trajectory.hpp)
  s.loop = loop_;
  s.ring.resize(kReplayReadAhead);
  s.batch.resize(kReplayBatch);
  s.loader = std::thread([&s] { s.run(); });
  while (s.head.load(std::memory_order_acquire) < 2 && !s.ended.load(std::memory_order_acquire))
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  if (s.failed.load(std::memory_order_acquire)) throw Error(s.failure);
  if (s.head.load(std::memory_order_acquire) == 0)
    throw Error(source_->description() + ": the recording holds no samples to replay");
}

// The loader stops (Stream's destructor) before the source it reads goes.
ReplayDevice::~ReplayDevice() { stream_.reset(); }

DeviceInfo ReplayDevice::info() const {
  DeviceInfo out;
  out.name = "replay";
  out.description = fmt::format("{} ({} samples, {:.3f} s{})", source_->description(), rows_, duration(),
                                loop_ ? ", looping" : "");
  out.renders_force = false;
  return out;
}

// The playback rule (common/trajectory.hpp): the start for a time before it, a period of the
// recording's duration when looping.
double ReplayDevice::recording_time(double now) const {
  return first_t_ + playback_offset(now, duration(), loop_);
}

bool ReplayDevice::finished(double now) const {
  return !loop_ && playback_offset(now, duration(), false) > duration();
}

// The haptic pose between the two frames around the played time (the playback cursor), the
// segment's velocities, the buttons of the frame at or before it.
DeviceState ReplayDevice::read(double now) {
  if (stream_) return read_stream(now);
  const Frames haptic{&frames_, &ReplayFrame::haptic};
  const Pose pose = cursor_.at(haptic, recording_time(now));
  const SegmentVelocity velocity = cursor_.velocity(haptic);
  DeviceState state;
  state.buttons = frames_[cursor_.at_or_before()].buttons;
  state.stamp = now;
  state.sequence = ++sequence_;
  state.valid = !finished(now);
  state.pose = pose;
  state.velocity = velocity.linear;
  state.angular_velocity = velocity.angular;
  return state;
}

void ReplayDevice::write(const Vec3& /*force*/, const Vec3& /*torque*/) {}

// In memory, a fresh playback cursor (any time, any order); streamed, the source's look-up.
Pose ReplayDevice::recorded_graphic(double now) const {
  const double time = recording_time(now);
  if (stream_) return source_->frame_at(time).graphic;
  PlaybackCursor<Frames> graphic_cursor;
  return graphic_cursor.at(Frames{&frames_, &ReplayFrame::graphic}, time);
}

// The streamed read: the playback cursor over the loaded entries from the servo's own (the entries
// carry their play time, loops unrolled); the entries before the one at or before the played time go
// back to the loader (servo time only goes forward); the last loaded pose is held when the loader has
// not caught up (an underrun).
DeviceState ReplayDevice::read_stream(double now) {
  Stream& s = *stream_;
  const double elapsed = playback_offset(now, duration(), false);
  const Stream::Loaded loaded{&s, s.cursor, s.head.load(std::memory_order_acquire)};
  const Pose pose = s.playback.at(loaded, elapsed);
  const SegmentVelocity velocity = s.playback.velocity(loaded);
  const std::uint64_t c = s.playback.at_or_before();
  if (c != s.cursor) {
    s.cursor = c;
    s.tail.store(c, std::memory_order_release);
  }
  const Stream::Entry& a = loaded.entry(c);
  DeviceState state;
  state.buttons = a.frame.buttons;
  state.stamp = now;
  state.sequence = ++sequence_;
  state.valid = !finished(now);
  state.pose = pose;
  state.velocity = velocity.linear;
  state.angular_velocity = velocity.angular;
  if (c + 1 >= loaded.end() && !s.ended.load(std::memory_order_acquire) && state.valid && elapsed > a.play)
    s.underruns.fetch_add(1, std::memory_order_relaxed);
  return state;
}

std::size_t ReplayDevice::buffered_samples() const { return stream_ ? stream_->held() : frames_.size(); }

std::size_t ReplayDevice::max_buffered_samples() const {
  return stream_ ? stream_->max_held.load(std::memory_order_relaxed) : frames_.size();
}

bool ReplayDevice::ready(double now) const {
  if (!stream_) return true;
  const Stream& s = *stream_;
  if (s.ended.load(std::memory_order_acquire)) return true;
  const std::uint64_t head = s.head.load(std::memory_order_acquire);
  const double elapsed = playback_offset(now, duration(), false);
  return head > 0 && s.ring[(head - 1) % s.ring.size()].play > elapsed;
}

std::uint64_t ReplayDevice::underruns() const {
  return stream_ ? stream_->underruns.load(std::memory_order_relaxed) : 0;
}

}  // namespace cariesim
