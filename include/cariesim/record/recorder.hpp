#pragma once
/// Session records in SQLite (DESIGN.md §5): session metadata, the sample stream at the servo rate,
/// and events (state changes, overruns, soft-tissue contacts above a force threshold). WAL mode;
/// samples are batched into transactions by a writer thread (never the servo thread), so a crash
/// loses at most the last batch (<= 100 ms). Replay and CSV export read the same file.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/device/device.hpp"
#include "cariesim/servo/servo.hpp"

namespace cariesim {

struct SessionInfo {
  std::string scene;          ///< scene name or file
  uint64_t scene_hash = 0;
  std::string device;         ///< device spec, e.g. "udp:47000"
  double rate_hz = 1000.0;    ///< Hz
  std::string version = CARIESIM_VERSION;
  std::string parameters;     ///< JSON of the lesion/material parameters at start
  std::string started_at;     ///< ISO 8601, UTC
};

struct RecordedEvent {
  double t = 0.0;             ///< s
  std::string kind;           ///< "state", "overrun", "soft_tissue", "param"
  std::string detail;
  double value = 0.0;         ///< e.g. the soft-tissue force (N)
};

struct RecorderOptions {
  double batch_seconds = 0.05;          ///< s, at most this much sample time per transaction (<= 0.1)
  std::size_t queue_capacity = 20000;   ///< samples buffered between servo and writer
  double soft_tissue_threshold = 1.0;   ///< N, a soft-tissue contact above this is an event
};

class Recorder {
 public:
  /// Creates (or truncates) the database and writes the session row. Throws cariesim::Error.
  Recorder(const std::filesystem::path& file, const SessionInfo& info, const RecorderOptions& options = {});
  ~Recorder();
  /// The queue the servo loop pushes samples into (ServoOptions::record).
  SpscQueue<ServoSample>& queue() { return *queue_; }
  void start();
  /// Drains the queue, commits, closes.
  void stop();
  [[nodiscard]] uint64_t written() const { return written_.load(); }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<SpscQueue<ServoSample>> queue_;
  std::atomic<uint64_t> written_{0};
};

struct Recording {
  SessionInfo info;
  std::vector<ServoSample> samples;
  std::vector<RecordedEvent> events;
};

/// Reads a whole recording; throws cariesim::Error naming the file and the problem.
Recording load_recording(const std::filesystem::path& file);
/// Writes session.csv, samples.csv and events.csv into `dir`.
void export_recording_csv(const std::filesystem::path& file, const std::filesystem::path& dir);

/// A device that plays a recording back (its haptic poses, in time).
std::unique_ptr<Device> make_replay_device(const std::filesystem::path& file, bool loop = false);

}  // namespace cariesim
