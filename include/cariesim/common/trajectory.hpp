#pragma once
/// Haptic-tool trajectories in memory and the one way they are played back: timed poses of the tool
/// frame (origin at the tip sphere's centre), interpolated linearly in position and by slerp in
/// rotation with the quaternion normalised (blend), played from a hint (PlaybackCursor) under one loop
/// rule (playback_offset). The scripted device (device/devices.hpp) plays a Trajectory, the replay
/// device (device/replay.hpp) recorded frames streamed through its read-ahead ring, both with this cursor;
/// `cariesim sim` and the experiments read trajectories from CSV files (device/trajectory_csv.hpp). The
/// rule is described in docs/records.md ("Playback").

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim {

/// The pose a fraction `u` (in [0, 1]) of the way from `a` to `b`: linear in position, slerp in
/// rotation, the quaternion normalised (slerp of two unit quaternions leaves unit length by rounding).
[[nodiscard]] Pose blend(const Pose& a, const Pose& b, double u);

/// The velocities of the segment from `a` to `b` travelled in `dt` s (dt > 0).
struct SegmentVelocity {
  Vec3 linear = Vec3::Zero();   ///< mm/s
  Vec3 angular = Vec3::Zero();  ///< rad/s, world frame
};
[[nodiscard]] SegmentVelocity segment_velocity(const Pose& a, const Pose& b, double dt);

/// The loop rule, one for every playback: the offset (s) from a trajectory's first sample played
/// `elapsed` s after it started. A negative or non-finite `elapsed` plays the start. Without looping
/// the offset is `elapsed` (past `duration` the player holds the last pose and reports it invalid);
/// looping, the period is `duration` (s, first to last sample): the last sample's time is the next
/// loop's start, so the last pose is reached and the first one follows at once, with no extra sample
/// interval. A trajectory of one sample (duration 0) plays its one pose.
[[nodiscard]] double playback_offset(double elapsed, double duration, bool loop);

/// Plays timed poses from a hint: sequential calls with increasing time cost constant time, and
/// nothing is allocated. `Source` is any indexed run of samples:
///
///   std::uint64_t first() const;            // the first index (a ring's oldest entry)
///   std::uint64_t end() const;              // one past the last index; end() > first()
///   double time(std::uint64_t i) const;     // s, increasing (equal at a loop's seam)
///   const Pose& pose(std::uint64_t i) const;
///
/// at(time) clamps to the first and last sample; inside it blends between the samples i, i+1 with
/// time(i) <= time <= time(i+1), found by walking on from the last call's segment (a few steps), else
/// by bisection; a time before the hint's sample starts over from first().
template <class Source>
class PlaybackCursor {
 public:
  /// The pose at `time` (s).
  Pose at(const Source& source, double time) {
    const std::uint64_t first = source.first();
    const std::uint64_t last = source.end() - 1;
    // Clamped at both ends (a non-finite time plays the start); the hint stays for the back.
    if (!(time > source.time(first))) {
      segment_ = current_ = first;
      return source.pose(first);
    }
    if (time >= source.time(last)) {
      current_ = last;
      return source.pose(last);
    }
    // Walk on from the last segment; start over when time went back before it.
    if (segment_ < first || segment_ >= last || source.time(segment_) > time) segment_ = first;
    std::uint64_t steps = 0;
    while (source.time(segment_ + 1) < time && steps < kMaxWalk) {
      ++segment_;
      ++steps;
    }
    // Far ahead: bisect for the first sample at or after `time` (where the walk would stop).
    if (source.time(segment_ + 1) < time) {
      std::uint64_t lo = segment_ + 1;  // time(lo) < time
      std::uint64_t hi = last;          // time(hi) > time
      while (hi - lo > 1) {
        const std::uint64_t mid = lo + (hi - lo) / 2;
        (source.time(mid) < time ? lo : hi) = mid;
      }
      segment_ = lo;
    }
    const double ta = source.time(segment_);
    const double dt = source.time(segment_ + 1) - ta;
    const double u = dt > 0.0 ? (time - ta) / dt : 1.0;
    current_ = u >= 1.0 ? segment_ + 1 : segment_;
    // At a loop's seam (the next sample at the same time) the next loop's first sample plays.
    if (u >= 1.0 && current_ + 1 < source.end() && !(source.time(current_ + 1) > time))
      return source.pose(++current_);
    return blend(source.pose(segment_), source.pose(segment_ + 1), u);
  }

  /// The index of the last sample at or before the last at()'s time (its buttons, state, ...); the
  /// samples before it are no longer needed while time increases.
  [[nodiscard]] std::uint64_t at_or_before() const { return current_; }
  /// The velocities of the segment that starts at at_or_before(); zero at the last sample and across
  /// a loop's seam (a segment of no duration).
  [[nodiscard]] SegmentVelocity velocity(const Source& source) const {
    if (current_ + 1 >= source.end()) return {};
    const double dt = source.time(current_ + 1) - source.time(current_);
    if (!(dt > 0.0)) return {};
    return segment_velocity(source.pose(current_), source.pose(current_ + 1), dt);
  }
  /// Forgets the hint (the next at() starts from the first sample).
  void reset() { segment_ = current_ = 0; }

 private:
  // Beyond this many steps forward a bisection is cheaper than walking.
  static constexpr std::uint64_t kMaxWalk = 16;
  std::uint64_t segment_ = 0;  // the hint: the segment of the last blend
  std::uint64_t current_ = 0;  // the sample at or before the last at()'s time
};

/// Timed poses of the tool frame.
struct Trajectory {
  std::vector<double> t;   ///< s, strictly increasing
  std::vector<Pose> pose;  ///< tool frame in the world

  /// True when it has no sample.
  [[nodiscard]] bool empty() const { return t.empty(); }
  [[nodiscard]] double start() const { return t.empty() ? 0.0 : t.front(); }  ///< s
  [[nodiscard]] double end() const { return t.empty() ? 0.0 : t.back(); }     ///< s
  /// The pose at time `time` (s), clamped to the first/last sample. Needs a non-empty trajectory.
  [[nodiscard]] Pose sample(double time) const;
  /// Appends a sample; the caller keeps times increasing.
  void add(double time, const Pose& p) {
    t.push_back(time);
    pose.push_back(p);
  }
};

/// Sequential sampling of a Trajectory without search from the start: the servo loop's way to follow
/// one (a PlaybackCursor over it).
class TrajectoryCursor {
 public:
  /// Follows `trajectory`, which must outlive the cursor and not be empty when at() is called.
  explicit TrajectoryCursor(const Trajectory& trajectory) : source_{&trajectory} {}
  /// The pose at `time` (s); efficient when times increase between calls. Allocation-free.
  Pose at(double time) { return cursor_.at(source_, time); }

 private:
  struct Source {
    const Trajectory* trajectory;
    [[nodiscard]] std::uint64_t first() const { return 0; }
    [[nodiscard]] std::uint64_t end() const { return trajectory->t.size(); }
    [[nodiscard]] double time(std::uint64_t i) const { return trajectory->t[i]; }
    [[nodiscard]] const Pose& pose(std::uint64_t i) const { return trajectory->pose[i]; }
  };
  Source source_;
  PlaybackCursor<Source> cursor_;
};

}  // namespace cariesim
