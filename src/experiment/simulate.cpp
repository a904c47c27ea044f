#include "cariesim/experiment/simulate.hpp"

#include <cmath>
#include <cstdio>
#include <memory>

#include "cariesim/common/error.hpp"

namespace cariesim {

std::vector<SimSample> simulate(const Model& model, const Trajectory& trajectory, double rate_hz,
                                const std::function<void(const SimSample&)>& on_step) {
  return simulate(model, model.defaults, trajectory, rate_hz, on_step);
}

std::vector<SimSample> simulate(const Model& model, const Params& params, const Trajectory& trajectory,
                                double rate_hz, const std::function<void(const SimSample&)>& on_step) {
  if (trajectory.empty()) throw Error("simulate: the trajectory is empty");
  if (!(rate_hz >= 1.0 && rate_hz <= 100000.0))
    throw Error("simulate: servo rate " + std::to_string(rate_hz) + " Hz is outside [1, 100000]");
  const double dt = 1.0 / rate_hz;
  const auto steps = static_cast<std::size_t>(std::floor((trajectory.end() - trajectory.start()) * rate_hz + 1e-9)) + 1;
  std::vector<SimSample> samples;
  samples.reserve(steps);
  TrajectoryCursor cursor(trajectory);
  State state(model, trajectory.pose.front());
  // Fixed time step (never the measured wall-clock delta).
  for (std::size_t i = 0; i < steps; ++i) {
    const double t = trajectory.start() + static_cast<double>(i) * dt;
    SimSample sample;
    sample.t = t - trajectory.start();
    sample.out = step(model, params, state, HapticInput{cursor.at(t), dt});
    if (on_step) on_step(sample);
    samples.push_back(sample);
  }
  return samples;
}

void write_sim_csv(const std::filesystem::path& file, const std::vector<SimSample>& samples) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> out(std::fopen(file.c_str(), "w"), &std::fclose);
  if (!out) throw Error(file.string() + ": cannot write the simulation CSV");
  std::fputs("t,h_px,h_py,h_pz,h_qw,h_qx,h_qy,h_qz,g_px,g_py,g_pz,g_qw,g_qx,g_qy,g_qz,"
             "fx,fy,fz,tx,ty,tz,state,depth,contacts,step_us\n", out.get());
  for (const SimSample& s : samples) {
    const Pose& h = s.out.haptic;
    const Pose& g = s.out.graphic;
    std::fprintf(out.get(),
                 "%.6f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,"
                 "%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%s,%.6f,%d,%.2f\n",
                 s.t, h.p.x(), h.p.y(), h.p.z(), h.q.w(), h.q.x(), h.q.y(), h.q.z(), g.p.x(), g.p.y(), g.p.z(),
                 g.q.w(), g.q.x(), g.q.y(), g.q.z(), s.out.force.x(), s.out.force.y(), s.out.force.z(),
                 s.out.torque.x(), s.out.torque.y(), s.out.torque.z(), state_name(s.out.state), s.out.depth,
                 s.out.contacts, s.out.step_us);
  }
  if (std::ferror(out.get())) throw Error(file.string() + ": write failed");
}

}  // namespace cariesim
