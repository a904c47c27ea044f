#include "cariesim/record/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <utility>

#include "cariesim/common/error.hpp"
#include "cariesim/common/trajectory.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/io/sqlite.hpp"
#include "record/schema.hpp"

namespace cariesim {

namespace {

// The sample columns, comma-separated, in kSampleColumns order.
std::string sample_columns() {
  std::string names;
  for (const char* column : record::kSampleColumns)
    names += names.empty() ? column : fmt::format(", {}", column);
  return names;
}

// What the replay device plays of a sample.
ReplayFrame frame_of(const ServoSample& s) { return {s.t, s.haptic, s.graphic, s.buttons}; }

// The in-memory samples as a PlaybackCursor source, of the haptic or the graphic pose.
struct Samples {
  const std::vector<ServoSample>* samples;
  Pose ServoSample::*which;
  [[nodiscard]] std::uint64_t first() const { return 0; }
  [[nodiscard]] std::uint64_t end() const { return samples->size(); }
  [[nodiscard]] double time(std::uint64_t i) const { return (*samples)[i].t; }
  [[nodiscard]] const Pose& pose(std::uint64_t i) const { return (*samples)[i].*which; }
};

}  // namespace

// A file: the reading connection (read() and rewind(), one thread at a time) with its batch query
// and position, and the look-up connection (sample_at(), any thread, under the mutex).
struct RecordingSource::File {
  std::unique_ptr<io::Database> reader;
  std::optional<io::Statement> batch;
  std::int64_t min_id = 0, max_id = 0;
  std::int64_t after = 0;  // the id of the last row read()

  mutable std::mutex lookup_mutex;
  std::unique_ptr<io::Database> lookup;
  std::optional<io::Statement> time_at, rows_from;
};

// Opens the file twice (the reading connection and the look-up one), reads the session row, the
// events, the id range and the first and last finite time from the two ends of the samples (rowid
// order is time order).
RecordingSource::RecordingSource(const std::filesystem::path& file)
    : description_(file.string()), file_(std::make_unique<File>()) {
  File& f = *file_;
  f.reader = record::open_recording(file);
  io::Database& db = *f.reader;
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
  f.min_id = *min_id;
  f.max_id = *max_id;
  f.after = f.min_id - 1;
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
  rows_ = static_cast<std::size_t>(f.max_id - f.min_id + 1);
  f.batch.emplace(
      db, fmt::format("SELECT {}, id FROM samples WHERE id > ? ORDER BY id LIMIT ?", sample_columns()));

  // The look-up connection.
  f.lookup = record::open_recording(file);
  f.time_at.emplace(*f.lookup, "SELECT t FROM samples WHERE id = ?");
  f.rows_from.emplace(
      *f.lookup, fmt::format("SELECT {} FROM samples WHERE id >= ? ORDER BY id LIMIT 2", sample_columns()));
}

// Keep the samples whose time is finite and increasing (a recording's are; anything else could not be
// played in order).
RecordingSource::RecordingSource(Recording recording, std::string description)
    : description_(std::move(description)),
      info_(std::move(recording.info)),
      events_(std::move(recording.events)) {
  samples_.reserve(recording.samples.size());
  for (const ServoSample& s : recording.samples) {
    if (!std::isfinite(s.t) || (!samples_.empty() && !(s.t > samples_.back().t))) continue;
    samples_.push_back(s);
  }
  rows_ = samples_.size();
  if (!samples_.empty()) {
    first_t_ = samples_.front().t;
    last_t_ = samples_.back().t;
  }
}

RecordingSource::~RecordingSource() = default;

// The next rows after the last one read (a file: one query, its work budget renewed, the file checked
// unchanged after it).
std::size_t RecordingSource::read(std::span<ReplayFrame> out) {
  if (!file_) {
    const std::size_t n = std::min(out.size(), samples_.size() - next_);
    for (std::size_t i = 0; i < n; ++i) out[i] = frame_of(samples_[next_ + i]);
    next_ += n;
    return n;
  }
  File& f = *file_;
  f.reader->renew_work_budget();
  io::Statement& batch = *f.batch;
  batch.reset();
  batch.bind(0, f.after);
  batch.bind(1, static_cast<std::int64_t>(out.size()));
  std::size_t rows = 0;
  int rc = SQLITE_ROW;
  while (rows < out.size() && (rc = batch.step()) == SQLITE_ROW) {
    f.after = batch.integer(static_cast<int>(record::kSampleColumns.size()));
    out[rows++] = frame_of(record::read_sample(batch));
  }
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) f.reader->fail("cannot read the samples");
  f.reader->check_input_unchanged();
  return rows;
}

void RecordingSource::rewind() {
  if (file_) {
    file_->after = file_->min_id - 1;
  } else {
    next_ = 0;
  }
}

ReplayFrame RecordingSource::frame_at(double t) const { return frame_of(sample_at(t)); }

// In memory: both poses by a fresh playback cursor (any time, any order), the other fields from the
// sample at or before the time. A file: a binary search over the ids for the last sample at or before
// the time, then that sample and the next one, blended alike.
ServoSample RecordingSource::sample_at(double time) const {
  if (!file_) {
    if (samples_.empty()) throw Error(description_ + ": the recording holds no samples to replay");
    PlaybackCursor<Samples> haptic_cursor;
    PlaybackCursor<Samples> graphic_cursor;
    const Pose haptic = haptic_cursor.at(Samples{&samples_, &ServoSample::haptic}, time);
    const Pose graphic = graphic_cursor.at(Samples{&samples_, &ServoSample::graphic}, time);
    ServoSample out = samples_[haptic_cursor.at_or_before()];
    out.haptic = haptic;
    out.graphic = graphic;
    out.t = std::min(time, samples_.back().t);
    return out;
  }
  File& f = *file_;
  const std::lock_guard<std::mutex> lock(f.lookup_mutex);
  io::Database& db = *f.lookup;
  db.renew_work_budget();
  io::Statement& time_at = *f.time_at;
  const auto t_of = [&](std::int64_t id) {
    time_at.reset();
    time_at.bind(0, id);
    if (time_at.step() != SQLITE_ROW) db.fail("cannot read the samples");
    return time_at.is_null(0) ? -std::numeric_limits<double>::infinity() : time_at.real(0);
  };
  std::int64_t lo = f.min_id;
  std::int64_t hi = f.max_id;
  while (lo < hi) {
    const std::int64_t mid = lo + (hi - lo + 1) / 2;
    if (t_of(mid) <= time) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  io::Statement& rows = *f.rows_from;
  rows.reset();
  rows.bind(0, lo);
  if (rows.step() != SQLITE_ROW) db.fail("cannot read the samples");
  ServoSample out = record::read_sample(rows);
  const int rc = rows.step();
  if (rc == SQLITE_ROW) {
    const ServoSample next = record::read_sample(rows);
    if (std::isfinite(out.t) && next.t > out.t && time > out.t) {
      const double u = std::clamp((time - out.t) / (next.t - out.t), 0.0, 1.0);
      out.haptic = blend(out.haptic, next.haptic, u);
      out.graphic = blend(out.graphic, next.graphic, u);
      out.t = std::min(time, last_t_);
    }
  } else if (rc != SQLITE_DONE) {
    db.fail("cannot read the samples");
  }
  return out;
}

std::unique_ptr<ReplayDevice> make_replay_device(const std::filesystem::path& file, bool loop) {
  return std::make_unique<ReplayDevice>(std::make_unique<RecordingSource>(file), loop);
}

std::unique_ptr<ReplayDevice> make_replay_device(Recording recording, bool loop, std::string description) {
  return std::make_unique<ReplayDevice>(
      std::make_unique<RecordingSource>(std::move(recording), std::move(description)), loop);
}

const RecordingSource* replayed_recording(const Device& device) {
  const auto* replay = dynamic_cast<const ReplayDevice*>(&device);
  return replay != nullptr ? dynamic_cast<const RecordingSource*>(&replay->source()) : nullptr;
}

ServoSample recorded(const ReplayDevice& device, double now) {
  const auto* recording = dynamic_cast<const RecordingSource*>(&device.source());
  if (recording == nullptr) throw Error(device.source().description() + ": not a recording");
  return recording->sample_at(device.recording_time(now));
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
                               return make_replay_device(std::filesystem::path(std::string(rest)), loop);
                             } catch (const Error& e) {
                               bad_device_spec(spec, e.what());
                             }
                           }});
}

}  // namespace cariesim
