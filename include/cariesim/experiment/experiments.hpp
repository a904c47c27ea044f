#pragma once
/// The paper's experiments, each reproducible with one command (DESIGN.md §1, §6):
/// `cariesim experiment friction|boundary|insertion|oral|all --out DIR`. Each writes per-run CSVs,
/// a figure per paper figure (matplotlib, Debian's python3-matplotlib) and summary.json.

#include <filesystem>
#include <string>
#include <vector>

#include "cariesim/scene/scene.hpp"

namespace cariesim {

struct ExperimentOptions {
  std::filesystem::path out;   ///< folder for CSVs, figures and summary.json (created)
  double rate_hz = 1000.0;     ///< Hz, servo rate of the simulated runs
  bool figures = true;         ///< draw the figures (needs python3 with matplotlib)
  bool quiet = false;          ///< no progress on stderr
  BuildOptions build;          ///< how scenes are built (cache, progress)
};

/// Names accepted by run_experiment, in the order `all` runs them.
std::vector<std::string> experiment_names();

/// Runs one experiment (or "all", each into its own subfolder) and returns the summary JSON it wrote.
/// Throws cariesim::Error for an unknown name or an unwritable folder.
std::string run_experiment(const std::string& name, const ExperimentOptions& options);

}  // namespace cariesim
