#include "figures.hpp"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "cariesim/common/error.hpp"

namespace cariesim::cli {

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

  // Debian's python3 carries python3-matplotlib; a python3 first on PATH may not.
  const char* python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::filesystem::path listing = dir / ("figures_" + name + ".txt");
  std::filesystem::remove(listing);
  const std::string command = std::string(python) + " '" + file.string() + "' '" + dir.string() + "'" +
                              (quiet ? " >/dev/null 2>&1" : " 1>&2");
  const int status = std::system(command.c_str());
  if (status != 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "warning: %s: figures not drawn (python3 with matplotlib needed); data written\n",
                 file.string().c_str());
    return figures;
  }

  // The figures the script listed.
  std::ifstream in(listing);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) figures.push_back(line);
  std::filesystem::remove(listing);
  return figures;
}

}  // namespace cariesim::cli
