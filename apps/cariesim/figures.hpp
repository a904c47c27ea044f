#pragma once
// The experiments' figures (DESIGN.md §6): matplotlib scripts (apps/cariesim/plots/plot_NAME.py,
// embedded at build time) run on an experiment's output folder. The core library writes the data;
// `cariesim experiment` draws the figures.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace cariesim::cli {

/// A figure script, embedded by cmake/embed_text.cmake.
struct PlotScript {
  std::string_view name;  // "plot_friction", ...
  std::string_view text;  // the script
};
extern const PlotScript kPlotScripts[];
extern const std::size_t kPlotScriptCount;

/// Writes `plot_<name>.py` into `dir` and runs it with python3 (matplotlib). Returns the figure files
/// the script reported, or an empty list (with a warning on stderr) when there is no script for
/// `name`, python3/matplotlib is missing or the script failed; the data are written either way.
std::vector<std::string> draw_figures(const std::filesystem::path& dir, const std::string& name, bool quiet);

}  // namespace cariesim::cli
