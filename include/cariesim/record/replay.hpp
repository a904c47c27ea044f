#pragma once
/// The replay device (`--device replay:FILE`): plays a recorded session back on the servo clock.
/// read(now) returns the recorded haptic pose at servo time `now`, played as every trajectory is
/// (PlaybackCursor, common/trajectory.hpp: linear in position, normalised slerp in rotation), so the
/// engine re-runs the session; the recorded graphic
/// pose (what the trainee saw) is there for the viewer to draw as a ghost tool:
///
///   auto device = make_replay_device(file);
///   auto* replay = dynamic_cast<ReplayDevice*>(device.get());
///   ... each frame, with the servo snapshot's time t:
///   const Pose ghost = replay->recorded_graphic(snapshot.t);
///
/// Servo time `now` plays recording time first_t + playback_offset(now, duration, loop) (first_t: the
/// first sample's t; the loop rule of common/trajectory.hpp: the period is the duration, first to last
/// sample); without looping the last pose is held and the reading turns invalid (so the force safety
/// layer zeroes the force).
///
/// A file is streamed: a loader thread reads the samples in batches of kReplayBatch rows into a
/// read-ahead buffer of kReplayReadAhead samples, ahead of the servo thread, which never waits, reads
/// nothing from the file and allocates nothing; memory is bounded whatever the recording's length,
/// and the first pose is there after one batch (bench/record_bench.cpp, BM_ReplayFirstPose). The
/// servo clock only goes forward: a file's read(now) holds the current pose for a `now` earlier than
/// the one before. recorded(now) and recorded_graphic(now) look the samples up in the file (any thread
/// but the servo's). An already loaded Recording is played from memory, at any time in any order.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cariesim/common/trajectory.hpp"
#include "cariesim/device/device.hpp"
#include "cariesim/record/recorder.hpp"

namespace cariesim {

/// Samples a streamed replay holds at most ahead of the servo thread (4 s at 4 kHz).
inline constexpr std::size_t kReplayReadAhead = 16384;
/// Rows the loader reads per query.
inline constexpr std::size_t kReplayBatch = 1024;
/// Events a replay keeps (the first ones by time); a recording holds a few per second.
inline constexpr std::size_t kReplayMaxEvents = 100000;

class ReplayDevice : public Device {
 public:
  /// Opens `file` (a recording, checked as any input: io/sqlite.hpp) and starts streaming it; returns
  /// once the first batch is there. Throws cariesim::Error when it cannot be read or holds no samples.
  explicit ReplayDevice(const std::filesystem::path& file, bool loop = false);
  /// Plays an already loaded recording (tests, tools); throws cariesim::Error when it has no samples.
  explicit ReplayDevice(Recording recording, bool loop = false, std::string description = "recording");
  ~ReplayDevice() override;
  ReplayDevice(const ReplayDevice&) = delete;
  ReplayDevice& operator=(const ReplayDevice&) = delete;

  /// name "replay", the file and the recorded length; renders_force = false (nothing to render on).
  [[nodiscard]] DeviceInfo info() const override;
  /// The recorded haptic pose at servo time `now` (s), its velocity and buttons. Servo thread:
  /// allocation-free, constant time while `now` increases.
  DeviceState read(double now) override;
  /// Accepted and ignored: a recording cannot feel anything.
  void write(const Vec3& force, const Vec3& torque) override;

  /// Recording time (s, the samples' t) played at servo time `now` (s).
  [[nodiscard]] double recording_time(double now) const;
  /// The recorded graphic pose (the ghost tool) at servo time `now` (s). Any thread.
  [[nodiscard]] Pose recorded_graphic(double now) const;
  /// The recorded sample at servo time `now` (s): both poses interpolated, every other field from the
  /// sample at or before that time. Any thread but the servo's (a streamed file is looked up in the
  /// file: a binary search over the samples' ids, which are in time order); throws cariesim::Error
  /// when the file cannot be read.
  [[nodiscard]] ServoSample recorded(double now) const;
  /// True when `now` (s) is past the end of a non-looping recording.
  [[nodiscard]] bool finished(double now) const;
  /// s, from the first to the last sample.
  [[nodiscard]] double duration() const { return last_t_ - first_t_; }
  /// The recording's session row and events.
  [[nodiscard]] const SessionInfo& session() const { return info_; }
  [[nodiscard]] const std::vector<RecordedEvent>& events() const { return events_; }
  /// Number of recorded samples (a file: its sample rows).
  [[nodiscard]] std::size_t size() const { return rows_; }

  /// A streamed file: the samples the read-ahead buffer holds now and the most it held so far (at most
  /// kReplayReadAhead); an in-memory recording: all of them.
  [[nodiscard]] std::size_t buffered_samples() const;
  [[nodiscard]] std::size_t max_buffered_samples() const;
  /// True when read(now) finds the samples around `now` loaded (always for an in-memory recording).
  [[nodiscard]] bool ready(double now) const;
  /// Servo cycles that found the read-ahead buffer empty before the end (the loader fell behind);
  /// each held the last pose.
  [[nodiscard]] std::uint64_t underruns() const;

 private:
  // The in-memory samples as a PlaybackCursor source, of the haptic or the graphic pose.
  struct Samples {
    const ReplayDevice* device;
    Pose ServoSample::*which;
    [[nodiscard]] std::uint64_t first() const { return 0; }
    [[nodiscard]] std::uint64_t end() const { return device->t_.size(); }
    [[nodiscard]] double time(std::uint64_t i) const { return device->t_[i]; }
    [[nodiscard]] const Pose& pose(std::uint64_t i) const { return device->samples_[i].*which; }
  };
  struct Stream;
  // The streamed read (servo thread) and look-up (other threads).
  DeviceState read_stream(double now);
  [[nodiscard]] ServoSample recorded_stream(double now) const;

  std::string description_;
  bool loop_ = false;
  double first_t_ = 0.0;  // s, the first and last played sample's t
  double last_t_ = 0.0;
  std::size_t rows_ = 0;
  std::unique_ptr<Stream> stream_;  // a streamed file; null for an in-memory recording
  SessionInfo info_;
  std::vector<RecordedEvent> events_;
  std::vector<double> t_;             // in memory: s, strictly increasing
  std::vector<ServoSample> samples_;  // in memory: aligned with t_
  PlaybackCursor<Samples> cursor_;    // in memory: the servo thread's
  uint64_t sequence_ = 0;
};

/// A device that plays a recording back (its haptic poses, in time): a ReplayDevice, dynamic_cast
/// to it for the recorded graphic pose (the ghost tool). Throws cariesim::Error when the file cannot
/// be read or holds no samples.
std::unique_ptr<Device> make_replay_device(const std::filesystem::path& file, bool loop = false);

/// Registers the `replay:FILE[:loop]` backend with the device factory (device/factory.hpp); call it at
/// start (the runtime's Session and the viewer do), any number of times. The replay device stays in
/// the record module: it reads the record's schema (record/schema.hpp), which the device module below
/// may not include.
void register_replay_device();

}  // namespace cariesim
