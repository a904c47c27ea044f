// `cariesim sim --scene S --trajectory T.csv --out O.csv [--rate HZ]` (DESIGN.md §6): headless run of
// the haptic step along a trajectory, one CSV row per servo cycle.
#include <algorithm>
#include <cstdio>
#include <vector>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/scene.hpp"
#include "commands.hpp"
#include "progress_printer.hpp"

namespace cariesim::cli {

namespace {

struct SimArgs {
  std::string scene = "oral-cavity";
  std::string trajectory;
  std::string out;
  double rate = 0.0;  // Hz; 0 = the scene's servo rate
  bool quiet = false;
};

int run_sim(const SimArgs& args) {
  const Trajectory trajectory = load_trajectory_csv(args.trajectory);
  BuildOptions build;
  if (!args.quiet) build.progress = progress_printer();
  const Model model = build_model(load_scene(args.scene), build);
  const double rate = args.rate > 0.0 ? args.rate : model.servo_rate;
  const std::vector<SimSample> samples = simulate(model, trajectory, rate);
  write_sim_csv(args.out, samples);

  // A short summary: steps, states visited, step time percentiles.
  if (!args.quiet) {
    std::vector<double> us;
    us.reserve(samples.size());
    int counts[4] = {0, 0, 0, 0};
    for (const SimSample& s : samples) {
      us.push_back(s.out.step_us);
      ++counts[static_cast<int>(s.out.state)];
    }
    std::sort(us.begin(), us.end());
    const auto pct = [&](double p) { return us[static_cast<std::size_t>(p * (us.size() - 1))]; };
    std::fprintf(stderr,
                 "sim: %zu steps at %.0f Hz -> %s\n  states: free %d, sliding %d, inserting %d, extracting %d\n"
                 "  step time: median %.1f us, p99 %.1f us, max %.1f us\n",
                 samples.size(), rate, args.out.c_str(), counts[0], counts[1], counts[2], counts[3], pct(0.5),
                 pct(0.99), us.back());
  }
  return 0;
}

}  // namespace

void register_sim(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<SimArgs>();
  CLI::App* sub = app.add_subcommand("sim", "Drive the haptic tool along a trajectory CSV, headless");
  sub->add_option("--scene", args->scene, "Built-in scene name or scene YAML file")->capture_default_str();
  sub->add_option("--trajectory", args->trajectory, "CSV with header t,px,py,pz,qw,qx,qy,qz (s, mm, unit quaternion)")
      ->required();
  sub->add_option("--out", args->out, "Output CSV, one row per servo step")->required();
  sub->add_option("--rate", args->rate, "Servo rate in Hz (default: the scene's)")->check(CLI::Range(1.0, 100000.0));
  sub->add_flag("--quiet", args->quiet, "No progress or summary");
  registry.add(sub, [args] { return run_sim(*args); });
}

}  // namespace cariesim::cli
