#include "experiment/common.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "cariesim/common/error.hpp"
#include "cariesim/io/csv.hpp"

namespace cariesim::experiment {

void write_text(const std::filesystem::path& file, std::string_view text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(file.string() + ": cannot write");
  out << text;
  if (!out) throw Error(file.string() + ": write failed");
}

void write_csv(const std::filesystem::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows, const std::vector<std::string>& text) {
  // Through the one CSV writer (io/csv.hpp), numbers as %.6g.
  io::CsvWriter csv(file);
  csv.header(header);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (const double v : rows[i]) csv.number(v, 6);
    if (i < text.size()) csv.text(text[i]);
    csv.end_row();
  }
  csv.close();
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
  // Objects whose every leaf is rigid (enamel, dentin, rigid blocks): rigid_objects, the step's rule.
  const ObjectMask rigid = rigid_objects(model);
  PlacedTool placed(model.tool.tree);
  double worst = 0.0;
  for (const SimSample& s : samples) {
    placed.place(s.out.graphic, 0.0);
    const ClosestPair c = closest(placed, model.objects, rigid, 0.0);
    if (std::isfinite(c.gap)) worst = std::max(worst, -c.gap);
  }
  return worst;
}

double max_force_step(const std::vector<SimSample>& samples) {
  double worst = 0.0;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    if (samples[i - 1].out.state == InteractionState::Free) continue;
    worst = std::max(worst, (samples[i].out.force - samples[i - 1].out.force).norm());
  }
  return worst;
}

void RunChecks::add(const Model& model, const std::vector<SimSample>& samples) {
  rigid_penetration = std::max(rigid_penetration, max_rigid_penetration(model, samples));
  force_step = std::max(force_step, max_force_step(samples));
}

void RunChecks::write(io::JsonWriter& summary) const {
  summary.field("max_rigid_penetration_mm", rigid_penetration);
  summary.field("max_force_step_N", force_step);
}

}  // namespace cariesim::experiment
