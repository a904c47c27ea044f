#pragma once
// Trajectories for probing a lesion of the oral scene (used by the oral experiment and its tests); the
// postures they probe in are public (cariesim/experiment/posture.hpp).
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/experiment/posture.hpp"
#include "cariesim/render/model.hpp"

namespace cariesim::experiment {

/// Tool orientation with the tip segment along `axis` (the tip points against it) and the working
/// end bent toward the in-plane direction at `roll` (rad).
Quat probe_orientation(const Vec3& axis, double roll);
/// Touch enamel next to the lesion, slide onto it, push along the tool's axis to beyond its floor,
/// hold, pull out. Optionally reports when the push starts and ends (s).
Trajectory probe_trajectory(const Model& model, const LesionModel& lesion, const Quat& q,
                            double* push_start = nullptr, double* push_end = nullptr);
/// Depth (mm) of the tip's apex below the lesion's surface point, along the lesion's normal.
double apex_depth(const Model& model, const LesionModel& lesion, const Pose& graphic);

}  // namespace cariesim::experiment
