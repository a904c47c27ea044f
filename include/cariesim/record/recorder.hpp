#pragma once
/// Session records in SQLite (docs/design.md §5): session metadata, the sample stream at the servo rate,
/// and events (state changes, overruns, soft-tissue contacts above a force threshold). WAL mode;
/// samples are batched into transactions by a writer thread (never the servo thread), so a crash
/// loses at most the last batch (<= 100 ms). Replay and CSV export read the same file. The schema,
/// the events and the CSV columns are documented in docs/records.md.
///
/// Threads: the servo loop pushes into queue() (never blocks, never touches the database); the
/// writer thread started by start() drains it, derives the events and commits; any other thread may
/// call status(), written() and record_event(). stop() the servo loop before stopping the recorder.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/common/lockfree.hpp"
#include "cariesim/record/sample.hpp"

namespace cariesim {

/// What was run: one row of the `session` table.
struct SessionInfo {
  std::string scene;                       ///< scene name or file
  uint64_t scene_hash = 0;                 ///< hash of the scene description (stored as 16 hex digits)
  std::string device;                      ///< device spec, e.g. "udp:47000"
  double rate_hz = 1000.0;                 ///< Hz, the servo rate (also the expected sample rate)
  std::string version = CARIESIM_VERSION;  ///< cariesim version that recorded
  std::string parameters;                  ///< JSON of the running parameters at start (docs/records.md)
  std::string started_at;  ///< ISO 8601, UTC (utc_now_iso8601); the recorder fills it in when empty
  std::string ended_at;    ///< ISO 8601, UTC, set by Recorder::stop(); empty after a crash
};

/// One row of the `events` table (kinds and the meaning of `value` per kind: docs/records.md).
struct RecordedEvent {
  double t = 0.0;         ///< s, servo time the event (or its episode) started
  std::string kind;       ///< "state", "penetration", "soft_tissue", "overrun", "safety", "engine",
                          ///< "button", "gap", or what record_event() was given (e.g. "param")
  std::string detail;     ///< e.g. "sliding->inserting", "peak_force", "stale_input"
  double value = 0.0;     ///< e.g. the soft-tissue peak force (N); per kind in docs/records.md
  int lesion = -1;        ///< lesion index involved, -1 when none
  double duration = 0.0;  ///< s, length of the episode (0 for instantaneous events)
};

struct RecorderOptions {
  double batch_seconds = 0.05;         ///< s, at most this much sample time per transaction, in (0, 0.1]
  std::size_t queue_capacity = 20000;  ///< samples buffered between servo and writer
  double soft_tissue_threshold = 1.0;  ///< N, a soft-tissue contact above this is an event
  bool overwrite = false;              ///< replace an existing file; otherwise an existing file is an error
  bool fsync_batches = false;          ///< fsync every batch (survives power loss, not only a crash)
  uint64_t max_bytes = 0;              ///< bytes, database size limit (0 = none; kHeldMaxBytes when
                                       ///< held); beyond it the recorder stops writing and reports "full"
  /// Keep the recording in memory while it runs and write the file only when it stops: nothing of
  /// the session (its parameters, samples, events) is on disk until then, so nobody at the station can
  /// read a trial's lesions off its live recording (trainee mode, docs/instructors.md). The file is
  /// claimed (created empty, owner-only) at once; a crash leaves it empty. About 230 bytes per sample
  /// in memory (0.8 GB per hour at 1 kHz), at most max_bytes.
  bool hold_until_stop = false;
};

/// bytes: the size limit of a held recording (RecorderOptions::hold_until_stop) when max_bytes is 0.
inline constexpr uint64_t kHeldMaxBytes = uint64_t{1} << 30;

/// What the writer has done so far; the viewer shows `ok` and `message`.
struct RecorderStatus {
  bool ok = true;                  ///< false once writing failed (disk full, I/O error); see message
  std::string message;             ///< the failure, naming the file and SQLite's reason; empty when ok
  uint64_t written = 0;            ///< samples committed
  uint64_t discarded = 0;          ///< samples dropped by the writer after a failure
  uint64_t events = 0;             ///< events committed
  uint64_t batches = 0;            ///< transactions committed
  uint64_t max_batch_samples = 0;  ///< largest batch (samples)
  double max_commit_us = 0.0;      ///< µs, longest COMMIT
  double total_commit_us = 0.0;    ///< µs, time spent in COMMIT over all batches
  uint64_t checkpoints = 0;        ///< WAL checkpoints into the database file (every 250 ms)
  double max_checkpoint_us = 0.0;  ///< µs, longest checkpoint
};

class Recorder {
 public:
  /// Creates the database and writes the session row. An existing `file` is an error unless
  /// options.overwrite is set (then it and its -wal/-shm files are replaced). Throws cariesim::Error
  /// naming the file and the reason (unwritable path, existing file, bad options, SQLite failure).
  Recorder(const std::filesystem::path& file, const SessionInfo& info, const RecorderOptions& options = {});
  /// Stops (drains and closes) if still running.
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  /// The queue the servo loop pushes samples into (ServoOptions::record in servo/servo.hpp).
  SpscQueue<ServoSample>& queue() { return *queue_; }
  /// Starts the writer thread.
  void start();
  /// Drains the queue, commits, checkpoints the WAL, closes. Safe to call twice.
  void stop();
  /// Samples committed so far.
  [[nodiscard]] uint64_t written() const { return written_.load(); }
  /// The writer's state (any thread).
  [[nodiscard]] RecorderStatus status() const;
  /// Queues an event from a non-servo thread (e.g. the viewer's parameter changes, kind "param");
  /// written with the next batch. Never call it from the servo thread (it takes a mutex).
  void record_event(const RecordedEvent& event);
  /// The database file.
  [[nodiscard]] const std::filesystem::path& file() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<SpscQueue<ServoSample>> queue_;
  std::atomic<uint64_t> written_{0};
};

/// A whole recording as read back.
struct Recording {
  SessionInfo info;
  std::vector<ServoSample> samples;    ///< in recording order (the `samples` table's id)
  std::vector<RecordedEvent> events;   ///< by start time
  int schema_version = 0;              ///< of the file
  double batch_seconds = 0.0;          ///< s, the recorder's batch length
  double soft_tissue_threshold = 0.0;  ///< N, the threshold the soft-tissue events used
};

/// Reads a whole recording (also one left by a crash: SQLite recovers the WAL); throws
/// cariesim::Error naming the file and the problem.
Recording load_recording(const std::filesystem::path& file);
/// What export_recording_csv wrote.
struct ExportSummary {
  std::size_t samples = 0;                   ///< rows of samples.csv
  std::size_t events = 0;                    ///< rows of events.csv
  std::size_t trajectory_rows = 0;           ///< rows of trajectory.csv (finite poses, increasing t)
  std::vector<std::filesystem::path> files;  ///< the files written
};

/// Writes session.csv, samples.csv, events.csv and trajectory.csv (the haptic poses in the
/// `cariesim sim` trajectory format) into `dir`, creating it. Columns and units: docs/records.md.
/// Throws cariesim::Error naming the file and the problem.
ExportSummary export_recording_csv(const std::filesystem::path& file, const std::filesystem::path& dir);

}  // namespace cariesim
