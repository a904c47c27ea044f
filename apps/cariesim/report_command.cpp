// `cariesim report DB... --out DIR [--course FILE]`: merges the study databases of many stations and
// writes the class's report: report.html (self-contained), NAME.csv per table (gradebook.csv: one row
// per trainee and criterion) and report.json (docs/reports.md); the course file's `criteria` grade
// each trainee pass or fail.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/training/course.hpp"
#include "cariesim/training/report.hpp"
#include "commands.hpp"
#include "figures.hpp"

namespace cariesim::cli {

namespace {

struct ReportArgs {
  std::vector<std::string> databases;
  std::string out;
  std::string course;
  bool no_figures = false;
  bool quiet = false;
};

int run_report(const ReportArgs& args) {
  // The course first (a bad one is refused before any database is read), then the stations.
  std::optional<training::Course> course;
  if (!args.course.empty()) course = training::load_course(args.course);
  const training::PassCriteria* criteria = course && course->criteria ? &*course->criteria : nullptr;
  if (course && !criteria && !args.quiet)
    std::fprintf(stderr, "warning: %s has no criteria: nobody is graded pass or fail\n", args.course.c_str());
  std::vector<std::filesystem::path> files(args.databases.begin(), args.databases.end());
  training::Report report = training::build_report(training::merge_study_databases(files), criteria);
  // The case pictures' data (teeth from the scene's meshes, lesions rebuilt from each case's seed).
  if (!args.no_figures) {
    std::vector<std::string> study_files;
    if (course && course->study_is_file) study_files.push_back(course->study);
    (void)training::add_case_views(report, study_files);
  }
  // The figures: plot_report.py (embedded) draws them from the CSVs in the staging folder.
  training::FigureDrawer draw;
  if (!args.no_figures)
    draw = [&args](const std::filesystem::path& dir) {
      std::vector<std::filesystem::path> figures;
      for (const std::string& f : draw_figures(dir, "report", args.quiet)) figures.emplace_back(f);
      return figures;
    };
  const training::ReportFiles written = training::write_report(report, args.out, draw);
  if (!args.quiet) {
    for (const std::string& w : report.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    std::fprintf(stderr,
                 "report: %zu database(s), %zu finished trial(s), %zu unfinished, %zu duplicate row(s) -> %s "
                 "(%zu figure(s))\n",
                 report.merged.inputs.size(), report.merged.finished.size(), report.merged.unfinished.size(),
                 report.merged.duplicates.size(), (written.dir / "report.html").string().c_str(),
                 written.figures);
  }
  return 0;
}

}  // namespace

void register_report(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* sub = app.add_subcommand("report", "Merge study databases into an HTML, CSV and JSON report");
  sub->add_option("DB", args->databases, "Study databases (one per station; duplicates are counted once)")
      ->required();
  sub->add_option("--out", args->out, "Folder for report.html, the tables' CSV files and report.json")
      ->required();
  sub->add_option(
      "--course", args->course,
      "The class's course file: its `criteria` grade each trainee pass or fail (docs/instructors.md)");
  sub->add_flag("--no-figures", args->no_figures, "Do not draw figures (no python3 needed)");
  sub->add_flag("--quiet", args->quiet, "No summary or warnings");
  registry.add(sub, [args] { return run_report(*args); });
}

}  // namespace cariesim::cli
