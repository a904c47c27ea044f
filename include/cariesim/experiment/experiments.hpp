#pragma once
/// The paper's experiments, each reproducible with one command (docs/design.md §1, §6):
/// `cariesim experiment friction|boundary|insertion|oral|all --out DIR`. Each writes per-run CSVs and
/// summary.json; figures are drawn by whoever runs them (`cariesim experiment` plugs in its
/// matplotlib scripts through ExperimentOptions::draw_figures), so the core library stays free of
/// plotting.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "cariesim/scene/model_builder.hpp"
#include "cariesim/spheretree/lesion.hpp"

namespace cariesim {

struct ExperimentOptions {
  std::filesystem::path out;  ///< folder for CSVs, figures and summary.json (created)
  double rate_hz = 1000.0;    ///< Hz, servo rate of the simulated runs
  /// Draws an experiment's figures from the data it wrote into `dir` (the experiment's `name`) and
  /// returns the figure files it made; listed in summary.json. Empty: no figures.
  std::function<std::vector<std::string>(const std::filesystem::path& dir, const std::string& name)>
      draw_figures;
  bool quiet = false;  ///< no progress on stderr
  BuildOptions build;  ///< how scenes are built (cache, progress)
  /// Parameter overrides applied to every scene an experiment loads (`--set`, docs/scene-format.md,
  /// "Overrides"); one that does not fit a scene fails the experiment, naming the override.
  std::vector<SceneOverride> overrides;
};

/// Names accepted by run_experiment, in the order `all` runs them.
std::vector<std::string> experiment_names();

/// mm, world x where a lesion's outline crosses the line y = y0 half its depth below `surface_z`
/// (mm), found from the lesion's -x side by bisection on its signed distance: the border the boundary
/// experiment (Fig. 12) and its tests slide across.
double lesion_border_x(const LesionShape& shape, double surface_z, double y0);

/// Runs one experiment (or "all", each into its own subfolder) and returns the summary JSON it wrote.
/// Throws cariesim::Error for an unknown name or an unwritable folder.
std::string run_experiment(const std::string& name, const ExperimentOptions& options);

}  // namespace cariesim
