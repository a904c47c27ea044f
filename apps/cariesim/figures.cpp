#include "figures.hpp"

#include <cerrno>
#include <cstdio>
#include <fstream>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/process.hpp"

namespace cariesim::cli {

namespace {

// s: the longest a figure script may run before it is killed (the report's figures of a large class
// take a few seconds).
constexpr double kScriptTimeout = 600.0;
// s: the longest the check `python3 -c "import matplotlib"` may take.
constexpr double kImportCheckTimeout = 60.0;
// Characters of a failed script's stderr shown in the warning (its end, where the error is).
constexpr std::size_t kShownStderr = 2000;

// The end of a child's stderr, for a message.
std::string stderr_tail(const io::ProcessResult& run) {
  std::string text = run.err;
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (text.size() > kShownStderr) text = "..." + text.substr(text.size() - kShownStderr);
  return text.empty() ? std::string("(no stderr)") : text;
}

// Why the figures were not drawn, in words: python3 missing, matplotlib missing (only when importing
// it fails with ModuleNotFoundError), or the script's own failure with its exit status and stderr.
std::string why_not_drawn(const std::string& python, const io::ProcessResult& run) {
  if (!run.started)
    return run.start_error == ENOENT ? python + " not found (figures need python3 with matplotlib)"
                                     : python + " " + run.describe();
  io::ProcessOptions check;
  check.timeout_s = kImportCheckTimeout;
  const io::ProcessResult import = io::run_process({python, "-c", "import matplotlib"}, check);
  if (import.started && !import.ok() && import.err.find("ModuleNotFoundError") != std::string::npos)
    return python + " has no matplotlib (install python3-matplotlib): " + stderr_tail(import);
  return "the script " + run.describe() + "; its stderr:\n" + stderr_tail(run);
}

}  // namespace

std::vector<std::string> draw_figures(const std::filesystem::path& dir, const std::string& name, bool quiet) {
  // The experiment's script, written next to its data so a researcher can re-run or edit it.
  const std::string script_name = "plot_" + name;
  const PlotScript* script = nullptr;
  for (std::size_t i = 0; i < kPlotScriptCount; ++i)
    if (kPlotScripts[i].name == script_name) script = &kPlotScripts[i];
  std::vector<std::string> figures;
  if (script == nullptr) {
    std::fprintf(stderr, "warning: no figure script for experiment '%s'; data written\n", name.c_str());
    return figures;
  }
  const std::filesystem::path file = dir / (script_name + ".py");
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << script->text;
    if (!out) throw Error(file.string() + ": cannot write");
  }

  // Debian's python3 carries python3-matplotlib; a python3 first on PATH may not. The script runs
  // from an argument vector (io/process.hpp, no shell), so no character of the folder's name is
  // interpreted; its output goes to stderr (or nowhere with --quiet), its stderr is kept for the
  // warning.
  const std::string python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::filesystem::path listing = dir / ("figures_" + name + ".txt");
  std::filesystem::remove(listing);
  io::ProcessOptions options;
  options.stdout_to = quiet ? io::ChildStdout::Discard : io::ChildStdout::ToStderr;
  options.timeout_s = kScriptTimeout;
  const io::ProcessResult run = io::run_process({python, file.string(), dir.string()}, options);
  if (!run.ok()) {
    std::fprintf(stderr, "warning: %s: figures not drawn: %s\n(data written)\n", file.string().c_str(),
                 why_not_drawn(python, run).c_str());
    return figures;
  }
  if (!quiet && !run.err.empty()) std::fprintf(stderr, "%s", run.err.c_str());

  // The figures the script listed.
  std::string text;
  try {
    text = io::read_file(listing, "figure list");
  } catch (const Error& e) {
    std::fprintf(stderr, "warning: figures not listed: %s\n", e.what());
    return figures;
  }
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    if (end > begin) figures.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  std::filesystem::remove(listing);
  return figures;
}

}  // namespace cariesim::cli
