#pragma once
/// Postures for probing a lesion: the tool's orientations around a lesion's normal and how close each
/// comes to the other objects while the tip travels in along its axis. The oral experiment probes
/// each lesion in its "correct posture" (docs/cli.md, `cariesim experiment oral`); the step
/// benchmarks (bench/step_bench.cpp) build their oral trajectories from them.
#include <vector>

#include "cariesim/render/model.hpp"

namespace cariesim::experiment {

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

}  // namespace cariesim::experiment
