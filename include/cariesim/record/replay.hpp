#pragma once
/// The replay device (`--device replay:FILE`): plays a recorded session back on the servo clock.
/// read(now) returns the recorded haptic pose at servo time `now`, interpolated between samples
/// (linear in position, slerp in rotation), so the engine re-runs the session; the recorded graphic
/// pose (what the trainee saw) is there for the viewer to draw as a ghost tool:
///
///   auto device = make_replay_device(file);
///   auto* replay = dynamic_cast<ReplayDevice*>(device.get());
///   ... each frame, with the servo snapshot's time t:
///   const Pose ghost = replay->recorded_graphic(snapshot.t);
///
/// Servo time `now` plays recording time first_t + now (first_t: the first sample's t), wrapping
/// around when looping; without looping the last pose is held and the reading turns invalid (so the
/// force safety layer zeroes the force). The recording is loaded once and never changes: the const
/// accessors are safe from any thread while the servo thread calls read().

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cariesim/device/device.hpp"
#include "cariesim/record/recorder.hpp"

namespace cariesim {

class ReplayDevice : public Device {
 public:
  /// Loads `file`; throws cariesim::Error when it cannot be read or holds no samples.
  explicit ReplayDevice(const std::filesystem::path& file, bool loop = false);
  /// Plays an already loaded recording (tests, tools); throws cariesim::Error when it has no samples.
  explicit ReplayDevice(Recording recording, bool loop = false, std::string description = "recording");

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
  /// sample at or before that time. Any thread.
  [[nodiscard]] ServoSample recorded(double now) const;
  /// True when `now` (s) is past the end of a non-looping recording.
  [[nodiscard]] bool finished(double now) const;
  /// s, from the first to the last sample.
  [[nodiscard]] double duration() const { return t_.back() - t_.front(); }
  /// The recording's session row and events.
  [[nodiscard]] const SessionInfo& session() const { return info_; }
  [[nodiscard]] const std::vector<RecordedEvent>& events() const { return events_; }
  /// Number of recorded samples.
  [[nodiscard]] std::size_t size() const { return t_.size(); }

 private:
  // The sample index i with t_[i] <= time < t_[i + 1] (clamped), searched from `hint`.
  [[nodiscard]] std::size_t segment(double time, std::size_t hint) const;
  [[nodiscard]] double blend_factor(std::size_t i, double time) const;

  std::string description_;
  bool loop_ = false;
  double period_ = 0.0;  // s, one loop: duration + one sample interval
  SessionInfo info_;
  std::vector<RecordedEvent> events_;
  std::vector<double> t_;             // s, strictly increasing
  std::vector<ServoSample> samples_;  // aligned with t_
  std::size_t cursor_ = 0;            // servo thread's segment
  uint64_t sequence_ = 0;
};

/// A device that plays a recording back (its haptic poses, in time): a ReplayDevice, dynamic_cast
/// to it for the recorded graphic pose (the ghost tool). Throws cariesim::Error when the file cannot
/// be read or holds no samples.
std::unique_ptr<Device> make_replay_device(const std::filesystem::path& file, bool loop = false);

}  // namespace cariesim
