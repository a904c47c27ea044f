#pragma once
/// The replay device (`--device replay:FILE[:loop]`): plays recorded tool poses back on the servo
/// clock. A ReplaySource hands it the recorded frames in time order (the record module's source reads
/// a recording, record/replay.hpp, and registers the `replay:` backend with device/factory.hpp);
/// read(now) returns the recorded haptic pose at servo time `now`, played as every trajectory is
/// (PlaybackCursor, common/trajectory.hpp: linear in position, normalised slerp in rotation), so the
/// engine re-runs the session; the recorded graphic pose (what the trainee saw) is there for the
/// viewer to draw as a ghost tool:
///
///   ReplayDevice device(std::make_unique<MySource>(...), /*loop=*/false);
///   ... each frame, with the servo snapshot's time t:
///   const Pose ghost = device.recorded_graphic(snapshot.t);
///
/// Servo time `now` plays recording time first_t + playback_offset(now, duration, loop) (first_t: the
/// first frame's t; the loop rule of common/trajectory.hpp: the period is the duration, first to last
/// frame); without looping the last pose is held and the reading turns invalid (so the force safety
/// layer zeroes the force). Frames whose time is not finite or not after the one before are skipped.
///
/// A streamed source is read by a loader thread in batches of kReplayBatch frames into a read-ahead
/// ring of kReplayReadAhead frames, ahead of the servo thread, which never waits, reads nothing from
/// the source and allocates nothing; memory is bounded whatever the recording's length, and the first
/// pose is there after one batch (bench/record_bench.cpp, BM_ReplayFirstPose). The servo clock only
/// goes forward: a streamed read(now) holds the current pose for a `now` earlier than the one before.
/// recorded_graphic(now) asks the source (ReplaySource::frame_at, any thread but the servo's). A
/// source in memory (ReplaySource::in_memory) is read whole at construction and played at any time in
/// any order. docs/records.md ("Replay") describes both.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/common/trajectory.hpp"
#include "cariesim/device/device.hpp"

namespace cariesim {

/// Frames a streamed replay holds at most ahead of the servo thread (4 s at 4 kHz).
inline constexpr std::size_t kReplayReadAhead = 16384;
/// Frames the loader asks its source for at a time.
inline constexpr std::size_t kReplayBatch = 1024;

/// One recorded instant of the tool.
struct ReplayFrame {
  double t = 0.0;        ///< s, recording time
  Pose haptic;           ///< the device's tool frame in the world (what the engine is driven with)
  Pose graphic;          ///< the tool frame drawn (the ghost tool)
  uint32_t buttons = 0;  ///< bit i = button i pressed
};

/// Where a ReplayDevice gets its frames: e.g. a recording file (record/replay.hpp). read() and rewind()
/// are called by one thread at a time (the loader's, or the constructor's); frame_at() by any thread
/// but the servo's, concurrently with them.
class ReplaySource {
 public:
  virtual ~ReplaySource() = default;
  /// What is played, for DeviceInfo::description (e.g. the file).
  [[nodiscard]] virtual std::string description() const = 0;
  /// Number of recorded frames (e.g. a file's sample rows, playable or not).
  [[nodiscard]] virtual std::size_t size() const = 0;
  /// s: the first and the last playable frame's t (finite, first_t() <= last_t()).
  [[nodiscard]] virtual double first_t() const = 0;
  [[nodiscard]] virtual double last_t() const = 0;
  /// True when every frame is at hand (in memory): the device reads them all at construction and
  /// plays at any time in any order. False: the device streams them through its read-ahead ring.
  [[nodiscard]] virtual bool in_memory() const { return false; }
  /// Writes the next frames in time order, at most out.size(), into `out` and returns how many;
  /// 0 at the end. Throws cariesim::Error when the source cannot be read.
  virtual std::size_t read(std::span<ReplayFrame> out) = 0;
  /// Starts read() over from the first frame (a loop).
  virtual void rewind() = 0;
  /// The frame at recording time `t` (s): both poses interpolated between the frames around it
  /// (blend, common/trajectory.hpp), the buttons of the frame at or before it, t clamped to the last
  /// frame. Any thread but the servo's; throws cariesim::Error when the source cannot be read.
  [[nodiscard]] virtual ReplayFrame frame_at(double t) const = 0;
};

/// Plays a ReplaySource on the servo clock (see above).
class ReplayDevice : public Device {
 public:
  /// Plays `source`, looping when `loop`; a streamed source's loader thread starts now, and this
  /// returns once its first batch is there. Throws cariesim::Error when the source holds no playable
  /// frame or cannot be read.
  explicit ReplayDevice(std::unique_ptr<ReplaySource> source, bool loop = false);
  ~ReplayDevice() override;
  ReplayDevice(const ReplayDevice&) = delete;
  ReplayDevice& operator=(const ReplayDevice&) = delete;

  /// name "replay", the source and the recorded length; renders_force = false (nothing to render on).
  [[nodiscard]] DeviceInfo info() const override;
  /// The recorded haptic pose at servo time `now` (s), its velocity and buttons. Servo thread:
  /// allocation-free, lock-free, constant time while `now` increases.
  DeviceState read(double now) override;
  /// Accepted and ignored: a recording cannot feel anything.
  void write(const Vec3& force, const Vec3& torque) override;

  /// Recording time (s, the frames' t) played at servo time `now` (s).
  [[nodiscard]] double recording_time(double now) const;
  /// The recorded graphic pose (the ghost tool) at servo time `now` (s). Any thread but the servo's
  /// (a streamed source is asked: ReplaySource::frame_at).
  [[nodiscard]] Pose recorded_graphic(double now) const;
  /// True when `now` (s) is past the end of a non-looping recording.
  [[nodiscard]] bool finished(double now) const;
  /// s, from the first to the last frame.
  [[nodiscard]] double duration() const { return last_t_ - first_t_; }
  /// Number of recorded frames (ReplaySource::size; in memory: the playable ones).
  [[nodiscard]] std::size_t size() const { return rows_; }
  /// What is played (e.g. the record module's RecordingSource, for the recording's session row).
  [[nodiscard]] const ReplaySource& source() const { return *source_; }

  /// A streamed source: the frames the read-ahead ring holds now and the most it held so far (at most
  /// kReplayReadAhead); in memory: all of them.
  [[nodiscard]] std::size_t buffered_samples() const;
  [[nodiscard]] std::size_t max_buffered_samples() const;
  /// True when read(now) finds the frames around `now` loaded (always in memory).
  [[nodiscard]] bool ready(double now) const;
  /// Servo cycles that found the read-ahead ring empty before the end (the loader fell behind); each
  /// held the last pose.
  [[nodiscard]] std::uint64_t underruns() const;

 private:
  // The in-memory frames as a PlaybackCursor source, of the haptic or the graphic pose.
  struct Frames {
    const std::vector<ReplayFrame>* frames;
    Pose ReplayFrame::*which;
    [[nodiscard]] std::uint64_t first() const { return 0; }
    [[nodiscard]] std::uint64_t end() const { return frames->size(); }
    [[nodiscard]] double time(std::uint64_t i) const { return (*frames)[i].t; }
    [[nodiscard]] const Pose& pose(std::uint64_t i) const { return (*frames)[i].*which; }
  };
  struct Stream;
  // The streamed read (servo thread).
  DeviceState read_stream(double now);

  std::unique_ptr<ReplaySource> source_;
  bool loop_ = false;
  double first_t_ = 0.0;  // s, the first and last played frame's t
  double last_t_ = 0.0;
  std::size_t rows_ = 0;
  std::unique_ptr<Stream> stream_;   // a streamed source; null in memory
  std::vector<ReplayFrame> frames_;  // in memory: t strictly increasing
  PlaybackCursor<Frames> cursor_;    // in memory: the servo thread's
  uint64_t sequence_ = 0;
};

}  // namespace cariesim
