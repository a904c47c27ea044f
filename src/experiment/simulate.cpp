#include "cariesim/experiment/simulate.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include "cariesim/common/error.hpp"

namespace cariesim {

std::vector<SimSample> simulate(const Model& model, const Trajectory& trajectory, double rate_hz,
                                const std::function<void(const SimSample&)>& on_step) {
  return simulate(model, model.defaults, trajectory, rate_hz, on_step);
}

std::size_t sim_step_count(const Trajectory& trajectory, double rate_hz) {
  if (trajectory.empty()) throw Error("simulate: the trajectory is empty");
  if (!(rate_hz >= 1.0 && rate_hz <= 100000.0))
    throw Error("simulate: servo rate " + std::to_string(rate_hz) + " Hz is outside [1, 100000]");
  // Counted in floating point first: a span of 1e300 s must not wrap around a size_t.
  const double span = trajectory.end() - trajectory.start();  // s
  const double steps = std::floor(span * rate_hz + 1e-9) + 1.0;
  if (!(std::isfinite(steps) && steps <= kMaxSimSteps))
    throw Error(
        fmt::format("simulate: the trajectory spans {:g} s: {:g} steps at {:g} Hz, more than the {:g} "
                    "a run may have (split the trajectory or lower the rate)",
                    span, steps, rate_hz, kMaxSimSteps));
  return static_cast<std::size_t>(steps);
}

std::size_t simulate_each(const Model& model, const Params& params, const Trajectory& trajectory,
                          double rate_hz, const std::function<void(const SimSample&)>& on_step) {
  const std::size_t steps = sim_step_count(trajectory, rate_hz);
  const double dt = 1.0 / rate_hz;
  TrajectoryCursor cursor(trajectory);
  State state(model, trajectory.pose.front());
  // Fixed time step (never the measured wall-clock delta); one sample alive at a time.
  SimSample sample;
  for (std::size_t i = 0; i < steps; ++i) {
    const double t = trajectory.start() + static_cast<double>(i) * dt;
    sample.t = t - trajectory.start();
    sample.out = step(model, params, state, HapticInput{cursor.at(t), dt});
    if (on_step) on_step(sample);
  }
  return steps;
}

std::vector<SimSample> simulate(const Model& model, const Params& params, const Trajectory& trajectory,
                                double rate_hz, const std::function<void(const SimSample&)>& on_step) {
  std::vector<SimSample> samples;
  samples.reserve(sim_step_count(trajectory, rate_hz));
  simulate_each(model, params, trajectory, rate_hz, [&](const SimSample& sample) {
    if (on_step) on_step(sample);
    samples.push_back(sample);
  });
  return samples;
}

SimCsvWriter::SimCsvWriter(const std::filesystem::path& file) : out_(file) {
  out_.header({"t",    "h_px", "h_py", "h_pz",  "h_qw",  "h_qx",     "h_qy",   "h_qz", "g_px",
               "g_py", "g_pz", "g_qw", "g_qx",  "g_qy",  "g_qz",     "fx",     "fy",   "fz",
               "tx",   "ty",   "tz",   "state", "depth", "contacts", "step_us"});
}

SimCsvWriter::~SimCsvWriter() = default;

// One row: positions and forces with 6 decimals, quaternions with 9, the step time with 2.
void SimCsvWriter::write(const SimSample& s) {
  const Pose& h = s.out.haptic;
  const Pose& g = s.out.graphic;
  out_.fixed(s.t, 6);
  for (const Pose* pose : {&h, &g}) {
    for (int k = 0; k < 3; ++k) out_.fixed(pose->p[k], 6);
    out_.fixed(pose->q.w(), 9).fixed(pose->q.x(), 9).fixed(pose->q.y(), 9).fixed(pose->q.z(), 9);
  }
  for (int k = 0; k < 3; ++k) out_.fixed(s.out.force[k], 6);
  for (int k = 0; k < 3; ++k) out_.fixed(s.out.torque[k], 6);
  out_.text(state_name(s.out.state)).fixed(s.out.depth, 6).integer(s.out.contacts).fixed(s.out.step_us, 2);
  out_.end_row();
}

void SimCsvWriter::close() {
  if (closed_) return;
  closed_ = true;
  out_.close();
}

void write_sim_csv(const std::filesystem::path& file, const std::vector<SimSample>& samples) {
  SimCsvWriter out(file);
  for (const SimSample& s : samples) out.write(s);
  out.close();
}

}  // namespace cariesim
