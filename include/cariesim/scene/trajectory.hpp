#pragma once
/// Haptic-tool trajectory files: CSV with the header `t,px,py,pz,qw,qx,qy,qz` (s, mm, unit
/// quaternion w-x-y-z), as read by `cariesim sim`, the scripted device and the experiments. Poses
/// are of the tool frame (origin at the tip sphere's centre). The Trajectory type itself, and its
/// interpolation, is common/trajectory.hpp.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/trajectory.hpp"

namespace cariesim {

/// Parses trajectory CSV text; `origin` names it in messages. Throws cariesim::Error
/// "origin:line:column: message" on a missing column, a non-number, a non-finite value, a quaternion
/// whose length is not 1 within bridge::kUnitTolerance (the UDP bridge's rule), or times that do not
/// increase. Unit quaternions are normalised (rounding only). A UTF-8 byte order mark is skipped.
Trajectory parse_trajectory_csv(std::string_view text, const std::string& origin);
/// Reads a trajectory CSV file; a directory or an unreadable file is an error naming it.
Trajectory load_trajectory_csv(const std::filesystem::path& file);
/// Writes a trajectory CSV file with the standard header.
void save_trajectory_csv(const Trajectory& trajectory, const std::filesystem::path& file);

}  // namespace cariesim
