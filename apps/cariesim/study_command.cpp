// `cariesim study run|check|list` (docs/training.md, docs/cli.md): runs a whole study headless with a
// scripted device and an answers file into a study database, validates a study file, lists the
// built-in studies.
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/training/headless.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"
#include "commands.hpp"
#include "progress_printer.hpp"

namespace cariesim::cli {
namespace {

struct StudyRunArgs {
  std::string study;
  std::string participant;
  std::string device = "null";
  std::string device_profile;  // a hardware device's profile file
  std::string answers;
  std::string out;
  std::string station;
  std::optional<uint64_t> seed;  // unset: the study's, else drawn
  bool same_cases = false;       // every participant the trials of the seed itself (an exam)
  int trials = 0;                // 0: the study's
  double duration = 0.0;         // s per trial when the device does not end
  bool quiet = false;
  std::vector<std::string> sets;  // --set KEY=VALUE
};

// One line per study: its name, kind, trial count and description.
void print_study_line(const training::Study& s) {
  std::printf("%-18s %-16s %3d trials  %s\n", s.name.c_str(),
              std::string(training::study_kind_name(s.kind)).c_str(), s.trials, s.description.c_str());
}

// "check": what the study asks, after it parsed and its first trial could be made.
void print_check(const training::Study& s) {
  std::printf("ok: %s (%s)\n", s.name.c_str(), s.origin.c_str());
  std::printf("kind %s, %d trials, seed %s\n", std::string(training::study_kind_name(s.kind)).c_str(),
              s.trials, s.seed ? std::to_string(*s.seed).c_str() : "drawn per run");
  switch (s.kind) {
    case training::StudyKind::Tuning:
      std::printf("  scene %s, lesion %s, levels:", s.tuning.scene.c_str(), s.tuning.lesion.c_str());
      for (const auto g : s.tuning.levels) std::printf(" %s", std::string(training::grade_name(g)).c_str());
      std::printf("\n");
      for (const auto& p : s.tuning.parameters)
        std::printf("  slider %-5s [%g, %g] %s\n", p.name.c_str(), p.min, p.max, p.unit.c_str());
      break;
    case training::StudyKind::Boundary:
      std::printf(
          "  %zu cubes %g x %g x %g mm, %g mm apart; shapes %g mm, %g mm deep, mu_s %g mu_d %g, %g N/mm\n",
          s.boundary.shapes.size(), s.boundary.cube.x(), s.boundary.cube.y(), s.boundary.cube.z(),
          s.boundary.spacing, s.boundary.shape_size, s.boundary.depth, s.boundary.mu_s, s.boundary.mu_d,
          s.boundary.stiffness);
      break;
    case training::StudyKind::Diagnosis:
      std::printf("  scene %s, %zu sites, %zu listed cases%s, time limit %g s, detection margin %g mm\n",
                  s.diagnosis.scene.c_str(), s.diagnosis.sites.size(), s.diagnosis.cases.size(),
                  s.diagnosis.generate ? ", then drawn cases" : "", s.diagnosis.time_limit,
                  s.diagnosis.detection_margin);
      for (const auto& site : s.diagnosis.sites)
        std::printf("  site %-20s %-8s FDI %d %-16s region %g x %g mm\n", site.name.c_str(),
                    site.object.c_str(), site.fdi, site.site.c_str(), 2.0 * site.region[0],
                    2.0 * site.region[1]);
      break;
  }
}

int run_study(const StudyRunArgs& args) {
  // The study, the answers, the run (which opens the database), then every trial.
  const training::Study study = training::load_study(args.study);
  const training::ScriptedAnswers answers = training::load_answers(args.answers);
  training::RunOptions options;
  options.participant = args.participant;
  options.station = args.station;
  options.database = args.out;
  options.seed = args.seed;
  options.same_cases = args.same_cases;
  if (args.trials > 0) options.trials = args.trials;
  options.overrides = scene_overrides(args.sets);
  training::StudyRun run(study, options);
  training::HeadlessOptions headless;
  headless.device = args.device;
  headless.device_profile = args.device_profile;
  headless.duration = args.duration;
  if (!args.quiet) headless.build.progress = progress_printer();
  headless.on_trial = [&](const training::TrialResult& r) {
    if (args.quiet) return;
    std::fprintf(stderr, "study: trial %d/%d (seed %llu): %s\n", r.index + 1, run.trial_count(),
                 static_cast<unsigned long long>(r.seed), r.scores_json.c_str());
  };
  if (!args.quiet)
    std::fprintf(stderr, "study: %s for %s, %d trials, seed %llu, into %s\n", study.name.c_str(),
                 args.participant.c_str(), run.trial_count(), static_cast<unsigned long long>(run.seed()),
                 args.out.c_str());
  const auto results = training::run_headless(run, answers, headless);
  std::printf("%s: %zu trials of %s for %s written to %s\n", study.name.c_str(), results.size(),
              study.name.c_str(), args.participant.c_str(), args.out.c_str());
  return 0;
}

}  // namespace

void register_study(CLI::App& app, Registry& registry) {
  auto* study = app.add_subcommand(
      "study", "Training studies: run one headless, check a study file, list the built-ins");
  study->require_subcommand(1);

  auto args = std::make_shared<StudyRunArgs>();
  auto* run = study->add_subcommand("run", "Run a whole study with a scripted device and an answers file");
  run->add_option("study", args->study, "a built-in study name or a study YAML file")->required();
  run->add_option("--participant", args->participant, "participant id (letters, digits, - _ .)")->required();
  run->add_option("--device", args->device, "device of every trial: " + device_help())->capture_default_str();
  add_device_profile_option(run, args->device_profile);
  run->add_option("--answers", args->answers, "answers file (YAML, docs/training.md)")->required();
  run->add_option("--out", args->out, "study database (SQLite), created or appended to")->required();
  add_set_option(run, args->sets);
  run->add_option("--station", args->station, "station name in the database (default: the host name)");
  add_seed_option(run, args->seed, "study seed, 0 to 2^63-1 (default: the study's, else drawn)");
  run->add_flag("--same-cases", args->same_cases,
                "every participant the same cases, those of the seed (as a course's exam_seed); default: "
                "each participant their own");
  run->add_option("--trials", args->trials, "number of trials (default: the study's)")
      ->check(CLI::Range(1, 1000));
  run->add_option("--duration", args->duration, "seconds per trial when the device does not end (default 1)")
      ->check(finite_range(0.0, 3600.0));
  run->add_flag("--quiet", args->quiet, "only the final line");
  registry.add(run, [args] { return run_study(*args); });

  auto target = std::make_shared<std::string>();
  auto* check =
      study->add_subcommand("check", "Validate a study file or built-in study (makes its first trial)");
  check->add_option("study", *target, "a study YAML file or a built-in study name")->required();
  registry.add(check, [target] {
    const training::Study s = training::load_study(*target);
    (void)training::make_trial(s, 0, training::trial_seed(s.seed.value_or(1), 0));
    print_check(s);
    return 0;
  });

  auto* list = study->add_subcommand("list", "List the built-in studies");
  registry.add(list, [] {
    for (const std::string& name : training::builtin_study_names())
      print_study_line(training::load_study(name));
    return 0;
  });
}

}  // namespace cariesim::cli
