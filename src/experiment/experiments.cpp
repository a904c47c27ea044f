#include "cariesim/experiment/experiments.hpp"

#include <chrono>
#include <ctime>

#include "cariesim/common/error.hpp"
#include "experiment/common.hpp"

namespace cariesim {

namespace {

struct Entry {
  const char* name;
  void (*run)(const ExperimentOptions&, io::JsonWriter&);
};

const Entry kExperiments[] = {
    {"friction", experiment::run_friction},
    {"boundary", experiment::run_boundary},
    {"insertion", experiment::run_insertion},
    {"oral", experiment::run_oral},
};

// Runs one experiment into options.out and writes its summary.json.
std::string run_one(const Entry& e, const ExperimentOptions& options) {
  std::error_code ec;
  std::filesystem::create_directories(options.out, ec);
  if (ec) throw Error(options.out.string() + ": cannot create the output folder: " + ec.message());
  const auto start = std::chrono::steady_clock::now();
  io::JsonWriter summary;
  summary.begin_object();
  e.run(options, summary);
  // Figures from the data just written.
  const std::vector<std::string> figures =
      options.draw_figures ? options.draw_figures(options.out, e.name) : std::vector<std::string>{};
  summary.key("figures").begin_array();
  for (const std::string& f : figures) summary.value(f);
  summary.end_array();
  summary.field("rate_hz", options.rate_hz);
  summary.field("wall_seconds",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  summary.field("version", CARIESIM_VERSION);
  summary.end_object();
  experiment::write_text(options.out / "summary.json", summary.str() + "\n");
  return summary.str();
}

}  // namespace

std::vector<std::string> experiment_names() {
  std::vector<std::string> names;
  for (const Entry& e : kExperiments) names.emplace_back(e.name);
  return names;
}

std::string run_experiment(const std::string& name, const ExperimentOptions& options) {
  for (const Entry& e : kExperiments)
    if (name == e.name) return run_one(e, options);
  if (name != "all") {
    std::string known;
    for (const Entry& e : kExperiments) known += std::string(known.empty() ? "" : ", ") + e.name;
    throw Error("unknown experiment '" + name + "' (known: " + known + ", all)");
  }
  // All of them, each in its own folder, and one summary that holds theirs.
  std::string combined = "{";
  for (const Entry& e : kExperiments) {
    ExperimentOptions sub = options;
    sub.out = options.out / e.name;
    combined += std::string(combined.size() > 1 ? "," : "") + "\"" + e.name + "\":" + run_one(e, sub);
  }
  combined += "}";
  experiment::write_text(options.out / "summary.json", combined + "\n");
  return combined;
}

}  // namespace cariesim
