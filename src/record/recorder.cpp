#include "cariesim/record/recorder.hpp"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "record/event_deriver.hpp"
#include "record/schema.hpp"
#include "cariesim/io/sqlite.hpp"

namespace cariesim {

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// The writer's sleep when the queue is empty: short next to the 100 ms loss budget.
constexpr auto kIdleSleep = std::chrono::milliseconds(1);
// s: sample times this close to a batch window's end count as past it (i / rate is not exact).
constexpr double kTimeTolerance = 1e-9;
// How often the writer copies the WAL into the database file, by the wall clock and by sample time
// (whichever comes first, so a stream pushed faster than real time is bounded too).
constexpr auto kCheckpointInterval = std::chrono::milliseconds(250);
constexpr double kCheckpointSampleSeconds = 0.25;  // s
// bytes: the WAL file is truncated back to this size when it restarts after a checkpoint.
constexpr int64_t kWalSizeLimit = int64_t{4} << 20;

// Options and session values the schema cannot hold are refused before anything is created.
void check_arguments(const fs::path& file, const SessionInfo& info, const RecorderOptions& options) {
  const std::string where = file.string() + ": ";
  if (!(options.batch_seconds > 0.0 && options.batch_seconds <= 0.1))
    throw Error(where + "batch_seconds must be in (0, 0.1] s, got " + std::to_string(options.batch_seconds));
  if (options.queue_capacity == 0) throw Error(where + "queue_capacity must be at least 1");
  if (!(std::isfinite(options.soft_tissue_threshold) && options.soft_tissue_threshold >= 0.0))
    throw Error(where + "soft_tissue_threshold must be a finite force >= 0 N");
  if (!(std::isfinite(info.rate_hz) && info.rate_hz > 0.0))
    throw Error(where + "session rate_hz must be a positive finite rate, got " +
                std::to_string(info.rate_hz));
}

// Claims the path: creates the file exclusively (O_EXCL, so two recorders cannot share it and an
// existing recording is never lost by accident), replacing it only when `overwrite` is set. Stale
// -wal/-shm files beside it belong to no database any more and are removed, or SQLite would replay
// them into the new file.
void claim_file(const fs::path& file, bool overwrite, mode_t mode) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw Error(file.string() + ": is a directory, not a recording file");
  if (overwrite && fs::exists(file, ec) && !fs::remove(file, ec))
    throw Error(file.string() + ": cannot replace the existing file: " + ec.message());
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) {
    const int err = errno;
    if (err == EEXIST)
      throw Error(file.string() +
                  ": already exists; refusing to overwrite a recording (choose another file, or "
                  "replace it with --overwrite)");
    throw Error(file.string() + ": cannot create the recording: " + std::strerror(err));
  }
  ::close(fd);
  for (const char* suffix : {"-wal", "-shm", "-journal"}) fs::remove(file.string() + suffix, ec);
}

}  // namespace

struct Recorder::Impl {
  Impl(const fs::path& path, const SessionInfo& session, const RecorderOptions& opts)
      : file(path),
        options(opts),
        db_owner(opts.hold_until_stop
                     ? io::create_memory_database(path.string() + " (held in memory)")
                     : io::create_database(path)),
        db(*db_owner),
        deriver(opts.soft_tissue_threshold, 1.0 / session.rate_hz) {}

  void open_database(const SessionInfo& info);
  void run(SpscQueue<ServoSample>& queue, std::atomic<uint64_t>& written);
  void handle(const ServoSample& sample, std::atomic<uint64_t>& written);
  void begin(double t0);
  void commit(std::atomic<uint64_t>& written);
  void finish(std::atomic<uint64_t>& written);
  void fail(const std::string& what, int rc);
  void checkpoint_if_due();
  void write_held();
  bool external_pending();

  fs::path file;
  RecorderOptions options;
  std::unique_ptr<io::Database> db_owner;  // a new file, claimed with O_EXCL (defensive settings)
  io::Database& db;
  std::optional<io::Statement> insert_sample, insert_event, update_event, begin_tx, commit_tx;
  record::EventDeriver deriver;
  std::vector<record::EventDeriver::Change> changes;  // scratch, reused every batch

  std::thread writer;
  std::atomic<bool> stop_requested{false};
  bool started = false;
  bool closed = false;

  // The open batch (writer thread only).
  bool in_tx = false;
  double batch_t0 = 0.0;           // s, sample time of its first sample
  Clock::time_point batch_opened;  // wall time it was opened
  double last_t = 0.0;             // s, sample time of the last sample written
  double checkpoint_t = 0.0;       // s, sample time of the last checkpoint
  Clock::time_point checkpointed = Clock::now();  // wall time of the last checkpoint
  bool warned_checkpoint = false;                 // a checkpoint that could not finish was logged
  uint64_t batch_samples = 0;
  int64_t next_sample_id = 0;
  int64_t events_written = 0;
  bool failed = false;

  mutable std::mutex status_mutex;  // guards status (writer once per batch, any reader)
  RecorderStatus status;
  std::mutex external_mutex;  // guards external (record_event callers, writer per batch)
  std::vector<RecordedEvent> external;
};

// Pragmas, schema and the session row, committed before the first sample so a crash right after
// start still leaves a readable recording; then the statements the writer reuses.
void Recorder::Impl::open_database(const SessionInfo& info) {
  // A held recording is an in-memory database until stop() (write_held); the rest is the same.
  if (!options.hold_until_stop) {
    io::Statement mode(db, "PRAGMA journal_mode=WAL");
    if (mode.step() != SQLITE_ROW || mode.text(0) != "wal")
      db.fail("cannot switch to WAL mode (the file system may not support it)");
  }
  db.exec(options.fsync_batches ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL",
          "cannot set synchronous");
  db.exec("PRAGMA application_id=" + std::to_string(record::kApplicationId), "cannot set the application id");
  db.exec("PRAGMA busy_timeout=1000", "cannot set the busy timeout");
  // The writer checkpoints itself between batches (checkpoint_if_due), where no transaction is
  // open, so the checkpoint completes and the next batch restarts the WAL from its beginning; the
  // WAL file is cut back to kWalSizeLimit when it restarts.
  db.exec("PRAGMA wal_autocheckpoint=0", "cannot turn off automatic checkpoints");
  db.exec("PRAGMA journal_size_limit=" + std::to_string(kWalSizeLimit), "cannot limit the WAL size");
  if (options.hold_until_stop && options.max_bytes == 0) options.max_bytes = kHeldMaxBytes;
  if (options.max_bytes > 0) {
    int64_t page_size = 4096;
    {
      io::Statement page(db, "PRAGMA page_size");
      if (page.step() == SQLITE_ROW) page_size = page.integer(0);
    }
    const uint64_t pages = std::max<uint64_t>(2, options.max_bytes / static_cast<uint64_t>(page_size));
    db.exec("PRAGMA max_page_count=" + std::to_string(pages), "cannot set the size limit");
  }

  db.exec("BEGIN", "cannot begin the schema transaction");
  record::create_schema(db);
  io::Statement session(
      db,
      "INSERT INTO session (id, scene, scene_hash, device, rate_hz, version, parameters,"
      " started_at, ended_at, batch_seconds, soft_tissue_threshold)"
      " VALUES (1, ?, ?, ?, ?, ?, ?, ?, NULL, ?, ?)");
  session.bind(0, info.scene);
  session.bind(1, record::hash_to_hex(info.scene_hash));
  session.bind(2, info.device);
  session.bind(3, info.rate_hz);
  session.bind(4, info.version);
  session.bind(5, info.parameters);
  session.bind(6, info.started_at.empty() ? utc_now_iso8601() : info.started_at);
  session.bind(7, options.batch_seconds);
  session.bind(8, options.soft_tissue_threshold);
  if (session.step() != SQLITE_DONE) db.fail("cannot write the session row");
  db.exec("COMMIT", "cannot commit the session row");

  insert_sample.emplace(db, record::insert_sample_sql());
  insert_event.emplace(
      db, "INSERT INTO events (id, t, kind, detail, value, lesion, duration) VALUES (?, ?, ?, ?, ?, ?, ?)");
  update_event.emplace(db, "UPDATE events SET value = ?, duration = ? WHERE id = ?");
  begin_tx.emplace(db, "BEGIN");
  commit_tx.emplace(db, "COMMIT");
}

// The writer loop: drain the queue into the open batch, commit when the batch is old enough by the
// wall clock too (the servo may be paused), sleep briefly when idle, and finish after stop().
void Recorder::Impl::run(SpscQueue<ServoSample>& queue, std::atomic<uint64_t>& written) {
  try {
    ServoSample sample;
    for (;;) {
      const bool stopping = stop_requested.load(std::memory_order_acquire);
      std::size_t popped = 0;
      while (queue.pop(sample)) {
        handle(sample, written);
        ++popped;
      }
      const double age = std::chrono::duration<double>(Clock::now() - batch_opened).count();
      if (in_tx && age >= options.batch_seconds) commit(written);
      if (popped > 0) continue;
      if (!failed && external_pending()) {
        if (!in_tx) begin(batch_t0);
        commit(written);
      }
      if (stopping) break;
      std::this_thread::sleep_for(kIdleSleep);
    }
    finish(written);
  } catch (const std::exception& e) {
    fail(std::string("writer stopped: ") + e.what(), SQLITE_ERROR);
    db.close();
  }
}

// One sample: close the batch when this sample falls outside its time window, then insert it and
// derive its events. After a failure samples are only counted.
void Recorder::Impl::handle(const ServoSample& s, std::atomic<uint64_t>& written) {
  if (in_tx && !(s.t - batch_t0 < options.batch_seconds - kTimeTolerance)) commit(written);
  if (failed) {
    std::lock_guard lock(status_mutex);
    ++status.discarded;
    return;
  }
  if (!in_tx) begin(s.t);
  if (failed) return;
  record::bind_sample(*insert_sample, next_sample_id, s);
  const int rc = insert_sample->step();
  insert_sample->reset();
  if (rc != SQLITE_DONE) {
    ++batch_samples;  // this one is lost with the batch
    fail("cannot write sample " + std::to_string(next_sample_id), rc);
    return;
  }
  ++next_sample_id;
  ++batch_samples;
  last_t = s.t;
  deriver.add(s);
}

void Recorder::Impl::begin(double t0) {
  const int rc = begin_tx->step();
  begin_tx->reset();
  if (rc != SQLITE_DONE) {
    fail("cannot begin a batch", rc);
    return;
  }
  in_tx = true;
  batch_t0 = t0;
  batch_opened = Clock::now();
  batch_samples = 0;
}

bool Recorder::Impl::external_pending() {
  std::lock_guard lock(external_mutex);
  return !external.empty();
}

// Write the batch's events (new rows and growing episodes), then COMMIT and account for it.
void Recorder::Impl::commit(std::atomic<uint64_t>& written) {
  if (!in_tx || failed) return;
  {
    std::lock_guard lock(external_mutex);
    for (const RecordedEvent& e : external) deriver.add_external(e);
    external.clear();
  }
  changes.clear();
  deriver.take(changes);
  int64_t new_events = 0;
  for (const record::EventDeriver::Change& change : changes) {
    const RecordedEvent& e = change.event;
    io::Statement& statement = change.fresh ? *insert_event : *update_event;
    if (change.fresh) {
      statement.bind(0, change.id);
      statement.bind(1, e.t);
      statement.bind(2, e.kind);
      statement.bind(3, e.detail);
      statement.bind(4, e.value);
      statement.bind(5, static_cast<int64_t>(e.lesion));
      statement.bind(6, e.duration);
      ++new_events;
    } else {
      statement.bind(0, e.value);
      statement.bind(1, e.duration);
      statement.bind(2, change.id);
    }
    const int rc = statement.step();
    statement.reset();
    if (rc != SQLITE_DONE) {
      fail("cannot write event '" + e.kind + "'", rc);
      return;
    }
  }
  const auto started_at = Clock::now();
  const int rc = commit_tx->step();
  commit_tx->reset();
  const double commit_us = std::chrono::duration<double, std::micro>(Clock::now() - started_at).count();
  if (rc != SQLITE_DONE) {
    fail("cannot commit a batch", rc);
    return;
  }
  in_tx = false;
  // Checkpoint before the batch counts as written, so a reader that sees it written also sees the
  // database file up to date (to the last checkpoint).
  checkpoint_if_due();
  events_written += new_events;
  written.fetch_add(batch_samples, std::memory_order_release);
  std::lock_guard lock(status_mutex);
  status.written += batch_samples;
  status.events = static_cast<uint64_t>(events_written);
  ++status.batches;
  status.max_batch_samples = std::max(status.max_batch_samples, batch_samples);
  status.max_commit_us = std::max(status.max_commit_us, commit_us);
  status.total_commit_us += commit_us;
  batch_samples = 0;
}

// After stop(): close the open episodes, commit the last batch, stamp the session's end, checkpoint
// the WAL into the database and close. A failed recording keeps its committed prefix and no end time.
void Recorder::Impl::finish(std::atomic<uint64_t>& written) {
  deriver.finish();
  if (!failed) {
    if (!in_tx) begin(batch_t0);
    commit(written);
  }
  if (!failed) {
    io::Statement end(db, "UPDATE session SET ended_at = ? WHERE id = 1");
    end.bind(0, utc_now_iso8601());
    const int rc = end.step();
    if (rc != SQLITE_DONE) fail("cannot stamp the session's end", rc);
  }
  insert_sample.reset();
  insert_event.reset();
  update_event.reset();
  begin_tx.reset();
  commit_tx.reset();
  if (options.hold_until_stop)
    write_held();
  else if (db.try_exec("PRAGMA wal_checkpoint(TRUNCATE)") != SQLITE_OK && !failed)
    fail("cannot checkpoint the WAL", SQLITE_ERROR);
  if (db.close() != SQLITE_OK && !failed) fail("cannot close the database", SQLITE_ERROR);
}

// A held recording goes to its file in one piece (SQLite's online backup of the in-memory database
// into the claimed, empty file): what was committed, also the prefix of a recording that failed.
void Recorder::Impl::write_held() {
  try {
    const std::unique_ptr<io::Database> out_owner = io::create_database(file);
    io::Database& out = *out_owner;
    sqlite3_backup* backup = sqlite3_backup_init(out.get(), "main", db.get(), "main");
    if (backup == nullptr) out.fail("cannot write the held recording");
    const int step = sqlite3_backup_step(backup, -1);
    const int rc = sqlite3_backup_finish(backup);
    if (step != SQLITE_DONE || rc != SQLITE_OK) out.fail("cannot write the held recording");
    if (out.close() != SQLITE_OK) throw Error(file.string() + ": cannot close the written recording");
  } catch (const Error& e) {
    const bool first = !failed;
    failed = true;
    if (first) spdlog::error("recorder: {}", e.what());
    std::lock_guard lock(status_mutex);
    if (first) {
      status.ok = false;
      status.message = e.what();
    }
  }
}

// Between batches, every 250 ms of wall or sample time: a PASSIVE checkpoint on the writer's own
// connection. No transaction is open, so unless another process holds a read snapshot it copies the
// whole WAL into the database file (the .db alone then holds the stream up to here) and the next
// batch restarts the WAL. Its fsync stalls the writer, not the servo loop (the queue holds 20 s). A
// checkpoint that cannot finish (a reader holds a snapshot) is logged once and retried at the next.
void Recorder::Impl::checkpoint_if_due() {
  if (options.hold_until_stop) return;  // in memory: nothing to copy until stop()
  const auto now = Clock::now();
  if (now - checkpointed < kCheckpointInterval && last_t - checkpoint_t < kCheckpointSampleSeconds) return;
  int log_frames = 0;
  int copied_frames = 0;
  const int rc =
      sqlite3_wal_checkpoint_v2(db.get(), nullptr, SQLITE_CHECKPOINT_PASSIVE, &log_frames, &copied_frames);
  const double checkpoint_us = std::chrono::duration<double, std::micro>(Clock::now() - now).count();
  checkpointed = Clock::now();
  checkpoint_t = last_t;
  if ((rc != SQLITE_OK || copied_frames < log_frames) && !warned_checkpoint) {
    spdlog::warn("recorder: {}: checkpoint incomplete ({} of {} WAL frames copied): {}", file.string(),
                 copied_frames, log_frames, rc == SQLITE_OK ? "a reader holds the WAL" : db.message());
    warned_checkpoint = true;
  }
  std::lock_guard lock(status_mutex);
  ++status.checkpoints;
  status.max_checkpoint_us = std::max(status.max_checkpoint_us, checkpoint_us);
}

// A failure ends the writing (the committed prefix stays valid): roll back, log once, and publish
// the reason for the UI; later samples are counted as discarded.
void Recorder::Impl::fail(const std::string& what, int rc) {
  std::string message = file.string() + ": " + what;
  if (db.get()) message += ": " + db.message();
  if ((rc & 0xff) == SQLITE_FULL) message += " (disk or size limit full; recording stopped)";
  if (in_tx && db.get()) db.try_exec("ROLLBACK");
  in_tx = false;
  const bool first = !failed;
  failed = true;
  if (first) spdlog::error("recorder: {}", message);
  std::lock_guard lock(status_mutex);
  status.discarded += batch_samples;
  batch_samples = 0;
  if (first) {
    status.ok = false;
    status.message = message;
  }
}

Recorder::Recorder(const fs::path& file, const SessionInfo& info, const RecorderOptions& options) {
  check_arguments(file, info, options);
  // A held recording's file is owner-only: it will hold what the session hid while it ran.
  claim_file(file, options.overwrite, options.hold_until_stop ? 0600 : 0644);
  try {
    impl_ = std::make_unique<Impl>(file, info, options);
    impl_->open_database(info);
  } catch (...) {
    impl_.reset();
    std::error_code ec;
    fs::remove(file, ec);
    for (const char* suffix : {"-wal", "-shm"}) fs::remove(file.string() + suffix, ec);
    throw;
  }
  queue_ = std::make_unique<SpscQueue<ServoSample>>(options.queue_capacity);
}

Recorder::~Recorder() {
  try {
    stop();
  } catch (const std::exception& e) {
    spdlog::error("recorder: {}", e.what());
  }
}

void Recorder::start() {
  if (impl_->started || impl_->closed) return;
  impl_->started = true;
  impl_->writer = std::thread([this] { impl_->run(*queue_, written_); });
}

void Recorder::stop() {
  if (!impl_ || impl_->closed) return;
  if (!impl_->started) start();
  impl_->stop_requested.store(true, std::memory_order_release);
  if (impl_->writer.joinable()) impl_->writer.join();
  impl_->closed = true;
}

RecorderStatus Recorder::status() const {
  std::lock_guard lock(impl_->status_mutex);
  return impl_->status;
}

void Recorder::record_event(const RecordedEvent& event) {
  std::lock_guard lock(impl_->external_mutex);
  impl_->external.push_back(event);
}

const fs::path& Recorder::file() const { return impl_->file; }

}  // namespace cariesim
