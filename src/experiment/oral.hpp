#pragma once
// Postures and trajectories for probing a lesion of the oral scene (used by the oral experiment, its
// tests and the step benchmarks).
#include "cariesim/render/model.hpp"
#include "cariesim/scene/trajectory.hpp"

namespace cariesim::experiment {

/// Tool orientation with the tip segment along `axis` (the tip points against it) and the working
/// end bent toward the in-plane direction at `roll` (rad).
Quat probe_orientation(const Vec3& axis, double roll);
/// Smallest gap (mm, capped at 2) between the tool, away from its tip, and every object but the
/// lesion's caries, with the tool held along the lesion's normal above, at and below its surface.
double posture_clearance(const Model& model, const LesionModel& lesion, const Quat& q);
/// The roll about the lesion's normal with the most clearance (the "correct posture").
Quat best_posture(const Model& model, const LesionModel& lesion, double* clearance = nullptr);
/// Touch enamel next to the lesion, slide onto it, push in to beyond its bottom, hold, pull out.
/// Optionally reports when the push starts and ends (s).
Trajectory probe_trajectory(const Model& model, const LesionModel& lesion, const Quat& q,
                            double* push_start = nullptr, double* push_end = nullptr);

}  // namespace cariesim::experiment
