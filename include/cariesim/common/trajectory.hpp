#pragma once
/// Haptic-tool trajectories in memory: timed poses of the tool frame (origin at the tip sphere's
/// centre), interpolated linearly in position and by slerp in rotation. The scripted device follows
/// one; `cariesim sim` and the experiments read them from CSV files (scene/trajectory.hpp).

#include <cstddef>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim {

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

/// Sequential sampling without search from the start: the servo loop's way to follow a trajectory.
class TrajectoryCursor {
 public:
  /// Follows `trajectory`, which must outlive the cursor and not be empty when at() is called.
  explicit TrajectoryCursor(const Trajectory& trajectory) : trajectory_(&trajectory) {}
  /// The pose at `time` (s); efficient when times increase between calls. Allocation-free.
  Pose at(double time);

 private:
  const Trajectory* trajectory_;
  std::size_t segment_ = 0;
};

}  // namespace cariesim
