#include "cariesim/record/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/io/sqlite.hpp"
#include "record/schema.hpp"

namespace cariesim {

namespace {

// The loader's sleep when the read-ahead buffer is full.
constexpr auto kLoaderIdle = std::chrono::milliseconds(1);

// The sample columns, comma-separated, in kSampleColumns order.
std::string sample_columns() {
  std::string names;
  for (const char* column : record::kSampleColumns)
    names += names.empty() ? column : fmt::format(", {}", column);
  return names;
}

}  // namespace

// A streamed file: the loader thread and its connection, the read-ahead ring (written by the loader,
// read by the servo thread, lock-free: `head` entries written, `tail` the servo's current entry, so
// the loader writes only slots below tail + capacity), and the look-up connection.
struct ReplayDevice::Stream {
  struct Entry {
    double play = 0.0;  // s of servo time at which it plays (a loop's seam: the next loop's first
                        // entry plays at its last entry's time)
    ServoSample sample;
  };
  // The loaded entries [tail, head) as a PlaybackCursor source (common/trajectory.hpp).
  struct Loaded {
    const Stream* stream;
    std::uint64_t from, to;
    [[nodiscard]] std::uint64_t first() const { return from; }
    [[nodiscard]] std::uint64_t end() const { return to; }
    [[nodiscard]] const Entry& entry(std::uint64_t i) const { return stream->ring[i % stream->ring.size()]; }
    [[nodiscard]] double time(std::uint64_t i) const { return entry(i).play; }
    [[nodiscard]] const Pose& pose(std::uint64_t i) const { return entry(i).sample.haptic; }
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

  std::unique_ptr<io::Database> loader_db;
  std::int64_t min_id = 0, max_id = 0;
  double first_t = 0.0, last_t = 0.0, period = 0.0;
  bool loop = false;
  std::vector<Entry> ring;  // kReplayReadAhead entries, allocated once
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

  mutable std::mutex lookup_mutex;  // the look-up connection and its statements
  std::unique_ptr<io::Database> lookup_db;
  std::optional<io::Statement> time_at, rows_from;
  std::thread loader;  // last: started when everything above is in place, joined first
};

// The loader: a batch of rows whenever the ring has room for one, the samples whose time is finite,
// increasing and within the played range, each with its play time; the start again when looping.
void ReplayDevice::Stream::run() {
  try {
    io::Statement batch(*loader_db,
                        fmt::format("SELECT {}, id FROM samples WHERE id > ? ORDER BY id LIMIT {}",
                                    sample_columns(), kReplayBatch));
    std::int64_t after = min_id - 1;
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
      loader_db->renew_work_budget();
      batch.reset();
      batch.bind(0, after);
      std::size_t rows = 0;
      int rc = SQLITE_ROW;
      while ((rc = batch.step()) == SQLITE_ROW) {
        ++rows;
        after = batch.integer(static_cast<int>(record::kSampleColumns.size()));
        const ServoSample s = record::read_sample(batch);
        if (!std::isfinite(s.t) || !(s.t > last) || s.t > last_t) continue;
        last = s.t;
        Entry& e = ring[w % capacity];
        e.play = s.t - first_t + static_cast<double>(cycle) * period;
        e.sample = s;
        ++pushed_this_cycle;
        head.store(++w, std::memory_order_release);
        const auto now_held = static_cast<std::size_t>(w - tail.load(std::memory_order_acquire));
        if (now_held > max_held.load(std::memory_order_relaxed))
          max_held.store(now_held, std::memory_order_relaxed);
      }
      if (rc != SQLITE_DONE) loader_db->fail("cannot read the samples");
      loader_db->check_input_unchanged();
      if (rows > 0) continue;
      // The end: again from the start when looping (a cycle that played nothing, or a recording of
      // no duration, whose one pose is held, ends it too).
      if (!loop || pushed_this_cycle == 0 || !(period > 0.0)) break;
      ++cycle;
      pushed_this_cycle = 0;
      after = min_id - 1;
      last = -std::numeric_limits<double>::infinity();
    }
  } catch (const std::exception& e) {
    failure = e.what();
    failed.store(true, std::memory_order_release);
  }
  ended.store(true, std::memory_order_release);
}

// Opens the file twice (the loader's connection and the look-up one), reads the session row, the
// events, the first and last playable time from the two ends of the samples (rowid order is time
// order), and starts the loader; returns once its first batch is in.
ReplayDevice::ReplayDevice(const std::filesystem::path& file, bool loop)
    : description_(file.string()), loop_(loop), stream_(std::make_unique<Stream>()) {
  Stream& s = *stream_;
  s.loader_db = record::open_recording(file);
  io::Database& db = *s.loader_db;
  Recording head;
  record::read_session(db, head);
  info_ = std::move(head.info);
  events_ = record::read_events(db, kReplayMaxEvents);

  // The id range (rowid min and max are each one look-up), then the first and last finite time.
  const auto id_at = [&](const char* aggregate) -> std::optional<std::int64_t> {
    io::Statement ids(db, fmt::format("SELECT {}(id) FROM samples", aggregate));
    if (ids.step() != SQLITE_ROW) db.fail("cannot read the samples");
    if (ids.is_null(0)) return std::nullopt;
    return ids.integer(0);
  };
  const std::optional<std::int64_t> min_id = id_at("min");
  const std::optional<std::int64_t> max_id = id_at("max");
  if (!min_id || !max_id) throw Error(description_ + ": the recording holds no samples to replay");
  s.min_id = *min_id;
  s.max_id = *max_id;
  const auto first_finite = [&](const char* order) -> std::optional<double> {
    io::Statement rows(db, fmt::format("SELECT t FROM samples ORDER BY id {}", order));
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW)
      if (!rows.is_null(0) && std::isfinite(rows.real(0))) return rows.real(0);
    if (rc != SQLITE_DONE) db.fail("cannot read the samples");
    return std::nullopt;
  };
  const std::optional<double> first = first_finite("ASC");
  const std::optional<double> last = first_finite("DESC");
  if (!first || !last || *last < *first)
    throw Error(description_ + ": the recording holds no samples to replay (no increasing finite times)");
  first_t_ = *first;
  last_t_ = *last;
  rows_ = static_cast<std::size_t>(s.max_id - s.min_id + 1);
  s.first_t = first_t_;
  s.last_t = last_t_;
  s.period = duration();  // the playback rule's period (common/trajectory.hpp)
  s.loop = loop_;

  // The look-up connection, then the loader; its first batch.
  s.lookup_db = record::open_recording(file);
  s.time_at.emplace(*s.lookup_db, "SELECT t FROM samples WHERE id = ?");
  s.rows_from.emplace(*s.lookup_db, fmt::format("SELECT {} FROM samples WHERE id >= ? ORDER BY id LIMIT 2",
                                                sample_columns()));
  s.ring.resize(kReplayReadAhead);
  s.loader = std::thread([&s] { s.run(); });
  while (s.head.load(std::memory_order_acquire) < 2 && !s.ended.load(std::memory_order_acquire))
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  if (s.failed.load(std::memory_order_acquire)) throw Error(s.failure);
  if (s.head.load(std::memory_order_acquire) == 0)
    throw Error(description_ + ": the recording holds no samples to replay");
}

ReplayDevice::~ReplayDevice() = default;

// Keep the samples whose time is finite and increasing (a recording's are; anything else could not be
// played in order).
ReplayDevice::ReplayDevice(Recording recording, bool loop, std::string description)
    : description_(std::move(description)),
      loop_(loop),
      info_(std::move(recording.info)),
      events_(std::move(recording.events)) {
  t_.reserve(recording.samples.size());
  samples_.reserve(recording.samples.size());
  for (const ServoSample& s : recording.samples) {
    if (!std::isfinite(s.t) || (!t_.empty() && !(s.t > t_.back()))) continue;
    t_.push_back(s.t);
    samples_.push_back(s);
  }
  if (t_.empty()) throw Error(description_ + ": the recording holds no samples to replay");
  first_t_ = t_.front();
  last_t_ = t_.back();
  rows_ = t_.size();
}

DeviceInfo ReplayDevice::info() const {
  DeviceInfo out;
  out.name = "replay";
  out.description =
      fmt::format("{} ({} samples, {:.3f} s{})", description_, rows_, duration(), loop_ ? ", looping" : "");
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

// The haptic pose between the two samples around the played time (the playback cursor), the
// segment's velocities, the buttons of the sample at or before it.
DeviceState ReplayDevice::read(double now) {
  if (stream_) return read_stream(now);
  const Samples haptic{this, &ServoSample::haptic};
  const Pose pose = cursor_.at(haptic, recording_time(now));
  const SegmentVelocity velocity = cursor_.velocity(haptic);
  DeviceState state;
  state.buttons = samples_[cursor_.at_or_before()].buttons;
  state.stamp = now;
  state.sequence = ++sequence_;
  state.valid = !finished(now);
  state.pose = pose;
  state.velocity = velocity.linear;
  state.angular_velocity = velocity.angular;
  return state;
}

void ReplayDevice::write(const Vec3& /*force*/, const Vec3& /*torque*/) {}

// Both poses by the playback cursor (a fresh one: any time, any order), the other fields from the
// sample at or before the time.
ServoSample ReplayDevice::recorded(double now) const {
  if (stream_) return recorded_stream(now);
  const double time = recording_time(now);
  PlaybackCursor<Samples> haptic_cursor;
  PlaybackCursor<Samples> graphic_cursor;
  const Pose haptic = haptic_cursor.at(Samples{this, &ServoSample::haptic}, time);
  const Pose graphic = graphic_cursor.at(Samples{this, &ServoSample::graphic}, time);
  ServoSample out = samples_[haptic_cursor.at_or_before()];
  out.haptic = haptic;
  out.graphic = graphic;
  out.t = std::min(time, t_.back());
  return out;
}

Pose ReplayDevice::recorded_graphic(double now) const { return recorded(now).graphic; }

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
  state.buttons = a.sample.buttons;
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

// The look-up: a binary search over the ids for the last sample at or before the time, then that
// sample and the next one, blended as in memory.
ServoSample ReplayDevice::recorded_stream(double now) const {
  Stream& s = *stream_;
  const double time = recording_time(now);
  const std::lock_guard<std::mutex> lock(s.lookup_mutex);
  io::Database& db = *s.lookup_db;
  db.renew_work_budget();
  io::Statement& time_at = *s.time_at;
  const auto t_of = [&](std::int64_t id) {
    time_at.reset();
    time_at.bind(0, id);
    if (time_at.step() != SQLITE_ROW) db.fail("cannot read the samples");
    return time_at.is_null(0) ? -std::numeric_limits<double>::infinity() : time_at.real(0);
  };
  std::int64_t lo = s.min_id;
  std::int64_t hi = s.max_id;
  while (lo < hi) {
    const std::int64_t mid = lo + (hi - lo + 1) / 2;
    if (t_of(mid) <= time) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  io::Statement& rows = *s.rows_from;
  rows.reset();
  rows.bind(0, lo);
  if (rows.step() != SQLITE_ROW) db.fail("cannot read the samples");
  ServoSample out = record::read_sample(rows);
  const int rc = rows.step();
  if (rc == SQLITE_ROW) {
    const ServoSample next = record::read_sample(rows);
    if (std::isfinite(out.t) && next.t > out.t && time > out.t) {
      const double f = std::clamp((time - out.t) / (next.t - out.t), 0.0, 1.0);
      out.haptic = blend(out.haptic, next.haptic, f);
      out.graphic = blend(out.graphic, next.graphic, f);
      out.t = std::min(time, last_t_);
    }
  } else if (rc != SQLITE_DONE) {
    db.fail("cannot read the samples");
  }
  return out;
}

std::size_t ReplayDevice::buffered_samples() const { return stream_ ? stream_->held() : samples_.size(); }

std::size_t ReplayDevice::max_buffered_samples() const {
  return stream_ ? stream_->max_held.load(std::memory_order_relaxed) : samples_.size();
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

std::unique_ptr<Device> make_replay_device(const std::filesystem::path& file, bool loop) {
  return std::make_unique<ReplayDevice>(file, loop);
}

// `replay:FILE[:loop]`, errors naming the spec as the built-in backends' do.
void register_replay_device() {
  register_device_backend({"replay", "replay:FILE[:loop]",
                           [](const std::string& spec, std::optional<std::string_view> argument,
                              const DeviceOptions& /*options*/) -> std::unique_ptr<Device> {
                             std::string_view rest = argument.value_or(std::string_view{});
                             const bool loop = strip_loop_option(rest);
                             if (rest.empty())
                               bad_device_spec(spec, "missing recording file (expected replay:FILE[:loop])");
                             try {
                               return make_replay_device(std::string(rest), loop);
                             } catch (const Error& e) {
                               bad_device_spec(spec, e.what());
                             }
                           }});
}

}  // namespace cariesim
