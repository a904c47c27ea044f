#include "experiment/common.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "cariesim/common/error.hpp"

namespace cariesim::experiment {

void write_text(const std::filesystem::path& file, std::string_view text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(file.string() + ": cannot write");
  out << text;
  if (!out) throw Error(file.string() + ": write failed");
}

void write_csv(const std::filesystem::path& file, const std::string& header,
               const std::vector<std::vector<double>>& rows, const std::vector<std::string>& text) {
  std::ostringstream out;
  out << header << '\n';
  char buf[32];
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (std::size_t j = 0; j < rows[i].size(); ++j) {
      std::snprintf(buf, sizeof buf, "%.6g", rows[i][j]);
      out << (j ? "," : "") << buf;
    }
    if (i < text.size()) out << ',' << text[i];
    out << '\n';
  }
  write_text(file, out.str());
}

std::vector<std::string> draw_figures(const std::filesystem::path& dir, std::string_view name,
                                      std::string_view script, bool quiet) {
  const std::filesystem::path file = dir / ("plot_" + std::string(name) + ".py");
  write_text(file, script);
  // Debian's python3 carries python3-matplotlib; a python3 first on PATH may not.
  const char* python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::filesystem::path listing = dir / ("figures_" + std::string(name) + ".txt");
  std::filesystem::remove(listing);
  const std::string command = std::string(python) + " '" + file.string() + "' '" + dir.string() + "'" +
                              (quiet ? " >/dev/null 2>&1" : " 1>&2");
  const int status = std::system(command.c_str());
  std::vector<std::string> figures;
  if (status != 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "warning: %s: figures not drawn (python3 with matplotlib needed); data written\n",
                 file.string().c_str());
    return figures;
  }
  std::ifstream in(listing);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) figures.push_back(line);
  std::filesystem::remove(listing);
  return figures;
}

void say(const ExperimentOptions& options, const std::string& line) {
  if (!options.quiet) std::fprintf(stderr, "%s\n", line.c_str());
}

Stats abs_stats(const std::vector<SimSample>& samples, double t0, double t1,
                double (*value)(const SimSample&)) {
  Stats s;
  double sum = 0.0;
  for (const SimSample& x : samples) {
    if (x.t < t0 || x.t > t1) continue;
    const double v = std::abs(value(x));
    sum += v;
    s.peak = std::max(s.peak, v);
    ++s.count;
  }
  s.mean = s.count > 0 ? sum / s.count : 0.0;
  return s;
}

double max_rigid_penetration(const Model& model, const std::vector<SimSample>& samples) {
  // Objects whose every leaf is rigid (enamel, dentin, rigid blocks), as the model builder found.
  ObjectMask rigid = 0;
  for (std::size_t i = 0; i < model.objects.size(); ++i)
    if (model.objects[i].surface_only) rigid |= ObjectMask{1} << i;
  PlacedTool placed(model.tool.tree);
  double worst = 0.0;
  for (const SimSample& s : samples) {
    placed.place(s.out.graphic, 0.0);
    const ClosestPair c = closest(placed, model.objects, rigid, 0.0);
    if (std::isfinite(c.gap)) worst = std::max(worst, -c.gap);
  }
  return worst;
}

}  // namespace cariesim::experiment
