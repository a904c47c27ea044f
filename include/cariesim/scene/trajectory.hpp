#pragma once
/// Haptic-tool trajectories: CSV files with the header `t,px,py,pz,qw,qx,qy,qz` (s, mm, unit
/// quaternion w-x-y-z), as read by `cariesim sim`, the scripted device and the experiments. Poses
/// are of the tool frame (origin at the tip sphere's centre). Between samples the pose is
/// interpolated: linear in position, slerp in rotation.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim {

struct Trajectory {
  std::vector<double> t;   ///< s, strictly increasing
  std::vector<Pose> pose;  ///< tool frame in the world

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

/// Parses trajectory CSV text; `origin` names it in messages. Throws cariesim::Error
/// "origin:line:column: message" on a missing column, a non-number, a non-finite value, a zero
/// quaternion, or times that do not increase. Quaternions are normalised.
Trajectory parse_trajectory_csv(std::string_view text, const std::string& origin);
/// Reads a trajectory CSV file.
Trajectory load_trajectory_csv(const std::filesystem::path& file);
/// Writes a trajectory CSV file with the standard header.
void save_trajectory_csv(const Trajectory& trajectory, const std::filesystem::path& file);

/// Sequential sampling without search from the start: the servo loop's way to follow a trajectory.
class TrajectoryCursor {
 public:
  explicit TrajectoryCursor(const Trajectory& trajectory) : trajectory_(&trajectory) {}
  /// The pose at `time` (s); efficient when times increase between calls.
  Pose at(double time);

 private:
  const Trajectory* trajectory_;
  std::size_t segment_ = 0;
};

}  // namespace cariesim
