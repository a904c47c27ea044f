// `cariesim experiment friction|boundary|insertion|oral|all --out DIR` (docs/design.md §6).
#include <cstdio>

#include "cariesim/experiment/experiments.hpp"
#include "commands.hpp"
#include "figures.hpp"
#include "progress_printer.hpp"

namespace cariesim::cli {

void register_experiment(CLI::App& app, Registry& registry) {
  struct Args {
    std::string name;
    std::string out;
    double rate = 1000.0;
    bool quiet = false;
    bool no_figures = false;
    std::vector<std::string> sets;  // --set KEY=VALUE
  };
  auto args = std::make_shared<Args>();
  CLI::App* sub =
      app.add_subcommand("experiment", "Run one of the paper's experiments (CSVs, figures, summary.json)");
  std::vector<std::string> names = experiment_names();
  names.push_back("all");
  sub->add_option("name", args->name, "friction | boundary | insertion | oral | all")
      ->required()
      ->check(CLI::IsMember(names));
  sub->add_option("--out", args->out, "Output folder")->required();
  sub->add_option("--rate", args->rate, "Servo rate of the simulated runs (Hz)")
      ->check(finite_range(100.0, 20000.0));
  add_set_option(sub, args->sets);
  sub->add_flag("--quiet", args->quiet, "No progress");
  sub->add_flag("--no-figures", args->no_figures, "Write data and summary only");
  registry.add(sub, [args] {
    ExperimentOptions options;
    options.out = args->out;
    options.rate_hz = args->rate;
    options.quiet = args->quiet;
    options.overrides = scene_overrides(args->sets);
    if (!args->no_figures) {
      const bool quiet = args->quiet;
      options.draw_figures = [quiet](const std::filesystem::path& dir, const std::string& name) {
        return draw_figures(dir, name, quiet);
      };
    }
    if (!args->quiet) options.build.progress = progress_printer();
    run_experiment(args->name, options);
    if (!args->quiet)
      std::fprintf(stderr, "experiment %s: results in %s\n", args->name.c_str(), args->out.c_str());
    return 0;
  });
}

}  // namespace cariesim::cli
