#pragma once
// Postures and trajectories for probing a lesion of the oral scene (used by the oral experiment, its
// tests and the step benchmarks).
#include <vector>

#include "cariesim/render/model.hpp"
#include "cariesim/scene/trajectory.hpp"

namespace cariesim::experiment {

/// Tool orientation with the tip segment along `axis` (the tip points against it) and the working
/// end bent toward the in-plane direction at `roll` (rad).
Quat probe_orientation(const Vec3& axis, double roll);
/// A candidate posture for probing a lesion: the tool's orientation and how close it comes to the
/// other objects while the tip travels along its axis from above the surface to the lesion's floor.
struct Posture {
  Quat q = Quat::Identity();
  double tilt = 0.0;        ///< rad between the tip segment and the lesion's normal
  double clearance = 0.0;   ///< mm, smallest gap (capped at 2) of the tool away from its tip
  int nearest_object = -1;  ///< object that gives the clearance (-1 when nothing is within 2 mm)
};
/// Clearance of one orientation (see Posture).
Posture evaluate_posture(const Model& model, const LesionModel& lesion, const Quat& q);
/// Orientations around the lesion's normal: tilts 0-30 degrees in 8 directions, 24 rolls each.
std::vector<Posture> posture_candidates(const Model& model, const LesionModel& lesion);
/// The "correct posture": the least tilted candidate whose clearance is at least 0.3 mm (the most
/// clearance when none is).
Posture best_posture(const Model& model, const LesionModel& lesion);
/// Touch enamel next to the lesion, slide onto it, push along the tool's axis to beyond its floor,
/// hold, pull out. Optionally reports when the push starts and ends (s).
Trajectory probe_trajectory(const Model& model, const LesionModel& lesion, const Quat& q,
                            double* push_start = nullptr, double* push_end = nullptr);
/// Depth (mm) of the tip's apex below the lesion's surface point, along the lesion's normal.
double apex_depth(const Model& model, const LesionModel& lesion, const Pose& graphic);

}  // namespace cariesim::experiment
