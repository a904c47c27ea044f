#pragma once
/// Headless simulation: drive the haptic tool along a trajectory at a fixed servo rate and record
/// every step (`cariesim sim`, the experiments, the benchmarks).

#include <filesystem>
#include <functional>
#include <vector>

#include "cariesim/render/step.hpp"
#include "cariesim/scene/trajectory.hpp"

namespace cariesim {

/// One servo cycle of a run.
struct SimSample {
  double t = 0.0;     ///< s since the trajectory's start
  StepOutput out;     ///< what the step returned (haptic and graphic pose, wrench, state, ...)
};

/// Runs the trajectory from its start to its end at `rate_hz` (the pose between samples is
/// interpolated: linear position, slerp rotation). The graphic tool starts at the first pose when it
/// is clear, else at the model's home pose. `params` are the materials, gains and limits of the run
/// (the model's defaults when omitted). `on_step` (optional) sees each sample as it is made.
std::vector<SimSample> simulate(const Model& model, const Params& params, const Trajectory& trajectory,
                                double rate_hz, const std::function<void(const SimSample&)>& on_step = {});
std::vector<SimSample> simulate(const Model& model, const Trajectory& trajectory, double rate_hz,
                                const std::function<void(const SimSample&)>& on_step = {});

/// Writes the rows of DESIGN.md §6: t, h_px..h_qz, g_px..g_qz, fx,fy,fz,tx,ty,tz, state, depth,
/// contacts, step_us. Throws cariesim::Error when the file cannot be written.
void write_sim_csv(const std::filesystem::path& file, const std::vector<SimSample>& samples);

}  // namespace cariesim
