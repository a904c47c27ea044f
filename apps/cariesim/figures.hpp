#pragma once
// The figures of `cariesim experiment` and `cariesim report` (docs/cli.md, docs/reports.md):
// matplotlib scripts (apps/cariesim/plots/plot_NAME.py, embedded at build time) run on an output
// folder through io/process.hpp (an argument vector, no shell). The libraries write the data; the
// command line draws the figures.
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
/// the script reported, or an empty list with a warning on stderr naming the cause: no script for
/// `name`, python3 not found, matplotlib missing (only when importing it fails), or the script's exit
/// status or signal with the end of its stderr. The data are written either way.
std::vector<std::string> draw_figures(const std::filesystem::path& dir, const std::string& name, bool quiet);

}  // namespace cariesim::cli
