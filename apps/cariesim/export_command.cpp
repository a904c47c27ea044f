// `cariesim export FILE --out DIR`: writes a session recording (a `--record` SQLite file) as CSV:
// session.csv, samples.csv, events.csv and trajectory.csv (docs/records.md).
#include <cstdio>
#include <memory>
#include <string>

#include "cariesim/record/recorder.hpp"
#include "commands.hpp"

namespace cariesim::cli {

namespace {

struct ExportArgs {
  std::string file;
  std::string out;
  bool quiet = false;
};

int run_export(const ExportArgs& args) {
  const ExportSummary summary = export_recording_csv(args.file, args.out);
  if (!args.quiet)
    std::fprintf(stderr, "export: %s -> %s: %zu samples, %zu events, %zu trajectory rows\n",
                 args.file.c_str(), args.out.c_str(), summary.samples, summary.events,
                 summary.trajectory_rows);
  return 0;
}

}  // namespace

void register_export(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* sub = app.add_subcommand("export", "Write a session recording as CSV files");
  sub->add_option("FILE", args->file, "Recording (SQLite) written by --record")->required();
  sub->add_option("--out", args->out, "Folder for session.csv, samples.csv, events.csv, trajectory.csv")
      ->required();
  sub->add_flag("--quiet", args->quiet, "No summary");
  registry.add(sub, [args] { return run_export(*args); });
}

}  // namespace cariesim::cli
