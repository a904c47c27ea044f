#pragma once
/// Replay of a recording: the record module's source for the device module's replay device
/// (device/replay.hpp, which plays it on the servo clock), the look-up of a whole recorded sample, and
/// the `replay:FILE[:loop]` backend of the device factory (device/factory.hpp):
///
///   register_replay_device();                      // once at start (Session and the viewer do)
///   auto device = make_device("replay:session.db");  // or make_replay_device(file, loop)
///   const RecordingSource* recording = replayed_recording(*device);  // the session row, events
///   const ServoSample sample = recorded(dynamic_cast<ReplayDevice&>(*device), now);
///
/// A file is streamed (the device's loader thread reads it in batches, ahead of the servo thread,
/// which reads nothing from the file); its look-ups (recorded(), the ghost tool's recorded_graphic())
/// are binary searches over the samples' ids, which are in time order, on a connection of their own.
/// An already loaded Recording is played from memory, at any time in any order. docs/records.md
/// ("Replay").

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cariesim/device/device.hpp"
#include "cariesim/device/replay.hpp"
#include "cariesim/record/recorder.hpp"

namespace cariesim {

/// Events a replay keeps (the first ones by time); a recording holds a few per second.
inline constexpr std::size_t kReplayMaxEvents = 100000;

/// A recording as a ReplaySource: a file (streamed, checked as any input: io/sqlite.hpp) or a
/// Recording in memory. Frames are the samples' t, haptic and graphic poses and buttons.
class RecordingSource final : public ReplaySource {
 public:
  /// Opens `file` (a recording); throws cariesim::Error when it cannot be read or holds no sample
  /// with a finite time.
  explicit RecordingSource(const std::filesystem::path& file);
  /// Holds `recording`'s samples whose time is finite and increasing (tests, tools).
  explicit RecordingSource(Recording recording, std::string description = "recording");
  ~RecordingSource() override;
  RecordingSource(const RecordingSource&) = delete;
  RecordingSource& operator=(const RecordingSource&) = delete;

  [[nodiscard]] std::string description() const override { return description_; }
  /// A file: its sample rows; in memory: the samples kept.
  [[nodiscard]] std::size_t size() const override { return rows_; }
  [[nodiscard]] double first_t() const override { return first_t_; }
  [[nodiscard]] double last_t() const override { return last_t_; }
  [[nodiscard]] bool in_memory() const override { return !file_; }
  std::size_t read(std::span<ReplayFrame> out) override;
  void rewind() override;
  [[nodiscard]] ReplayFrame frame_at(double t) const override;

  /// The recorded sample at recording time `t` (s): both poses interpolated, every other field from
  /// the sample at or before that time, t clamped to the last sample. Any thread but the servo's;
  /// throws cariesim::Error when the file cannot be read.
  [[nodiscard]] ServoSample sample_at(double t) const;
  /// The recording's session row and its first kReplayMaxEvents events.
  [[nodiscard]] const SessionInfo& session() const { return info_; }
  [[nodiscard]] const std::vector<RecordedEvent>& events() const { return events_; }

 private:
  struct File;

  std::string description_;
  std::size_t rows_ = 0;
  double first_t_ = 0.0;  // s, the first and last sample with a finite time
  double last_t_ = 0.0;
  SessionInfo info_;
  std::vector<RecordedEvent> events_;
  std::unique_ptr<File> file_;        // a file; null in memory
  std::vector<ServoSample> samples_;  // in memory: t strictly increasing
  std::size_t next_ = 0;              // in memory: the next sample read() hands out
};

/// A replay device playing the recording `file` (a RecordingSource); throws cariesim::Error when the
/// file cannot be read or holds no samples.
std::unique_ptr<ReplayDevice> make_replay_device(const std::filesystem::path& file, bool loop = false);
/// A replay device playing `recording` from memory; throws cariesim::Error when it has no samples.
std::unique_ptr<ReplayDevice> make_replay_device(Recording recording, bool loop = false,
                                                 std::string description = "recording");

/// The recording `device` plays back: null unless it is a ReplayDevice over a RecordingSource.
[[nodiscard]] const RecordingSource* replayed_recording(const Device& device);

/// The recorded sample `device` plays at servo time `now` (s) (RecordingSource::sample_at at its
/// recording_time). Any thread but the servo's; throws cariesim::Error when the device does not play
/// a recording or the file cannot be read.
[[nodiscard]] ServoSample recorded(const ReplayDevice& device, double now);

/// Registers the `replay:FILE[:loop]` backend with the device factory (device/factory.hpp); call it at
/// start (the runtime's Session and the viewer do), any number of times. It lives in the record
/// module because its source reads the record's schema, which the device module below may not
/// include.
void register_replay_device();

}  // namespace cariesim
