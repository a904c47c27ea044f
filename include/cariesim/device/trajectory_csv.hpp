#pragma once
/// Haptic-tool trajectory files: CSV with the header `t,px,py,pz,qw,qx,qy,qz` (s, mm, unit
/// quaternion w-x-y-z), as read by `cariesim sim`, the scripted device and the experiments. Poses
/// are of the tool frame (origin at the tip sphere's centre). The Trajectory type itself, and how it
/// is played, is common/trajectory.hpp. The files live in the device module, beside the input guard
/// whose unit-quaternion rule they apply, so that the device factory (device/factory.hpp) reads the
/// scripted device's path itself.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/trajectory.hpp"

namespace cariesim {

/// Bytes: the largest trajectory file read (a 10-minute 4 kHz recording exported as CSV is about
/// 360 MB); its lines are bounded by io::kMaxLineBytes.
inline constexpr std::uintmax_t kMaxTrajectoryBytes = std::uintmax_t{1} << 30;

/// Parses trajectory CSV text; `origin` names it in messages. Throws cariesim::Error
/// "origin:line:column: message" on a missing column, a non-number, a non-finite value, a quaternion
/// whose length is not 1 within kUnitTolerance (is_unit, device/input_guard.hpp: the rule of the
/// input guard and the UDP bridge), or times that do not increase. Unit quaternions are normalised
/// (rounding only). A UTF-8 byte order mark is skipped.
Trajectory parse_trajectory_csv(std::string_view text, const std::string& origin);
/// Reads a trajectory CSV file line by line (io::LineReader): a regular file of at most
/// kMaxTrajectoryBytes; a folder, FIFO or device is refused naming its kind, before any read.
Trajectory load_trajectory_csv(const std::filesystem::path& file);
/// Writes a trajectory CSV file with the standard header.
void save_trajectory_csv(const Trajectory& trajectory, const std::filesystem::path& file);

}  // namespace cariesim
