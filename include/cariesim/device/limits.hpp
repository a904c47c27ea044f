#pragma once
/// What a haptic device can render (its own type: the device module knows math and nothing else).

#include <algorithm>

#include "cariesim/common/math.hpp"

namespace cariesim {

/// A device's limits (defaults: the paper's Phantom Premium 3.0 6-DoF, §4.1.2).
struct DeviceLimits {
  double max_force = 22.0;                                                     ///< N
  double max_stiffness = 1.0;                                                  ///< N/mm
  double max_torque = 500.0;                                                   ///< N·mm
  double position_resolution = 0.02;                                           ///< mm
  Eigen::AlignedBox3d workspace{Vec3(-200, -200, -200), Vec3(200, 200, 200)};  ///< mm
};

/// The tighter of two sets of limits, field by field (the simulator's and what a device announced):
/// the smaller force, stiffness and torque, the coarser resolution, the common workspace.
inline DeviceLimits tighter(const DeviceLimits& a, const DeviceLimits& b) {
  DeviceLimits out;
  out.max_force = std::min(a.max_force, b.max_force);
  out.max_stiffness = std::min(a.max_stiffness, b.max_stiffness);
  out.max_torque = std::min(a.max_torque, b.max_torque);
  out.position_resolution = std::max(a.position_resolution, b.position_resolution);
  out.workspace = a.workspace.intersection(b.workspace);
  return out;
}

}  // namespace cariesim
