// `cariesim course hash`, `cariesim course check FILE` and `cariesim course prepare FILE`
// (docs/instructors.md): the instructor's passphrase hash for a course file, read from standard input
// (asked twice, without echo, at a terminal), a course file's check, and its cases built into the
// tree cache before class.
#include <fmt/format.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/spheretree/cache.hpp"
#include "cariesim/training/course.hpp"
#include "cariesim/training/study.hpp"
#include "commands.hpp"

namespace cariesim::cli {
namespace {

// One line of standard input without its line end; at a terminal, prompted on stderr without echo.
std::string read_passphrase(const char* prompt) {
  const bool tty = isatty(STDIN_FILENO) == 1;
  termios saved{};
  if (tty) {
    std::fputs(prompt, stderr);
    std::fflush(stderr);
    tcgetattr(STDIN_FILENO, &saved);
    termios quiet = saved;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    tcsetattr(STDIN_FILENO, TCSANOW, &quiet);
  }
  std::string line;
  const bool got = static_cast<bool>(std::getline(std::cin, line));
  if (tty) {
    tcsetattr(STDIN_FILENO, TCSANOW, &saved);
    std::fputs("\n", stderr);
  }
  if (!got) throw Error("no passphrase on standard input");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

int hash_command(int iterations) {
  // The passphrase (twice at a terminal), then its hash on stdout.
  const std::string passphrase = read_passphrase("instructor passphrase: ");
  if (isatty(STDIN_FILENO) == 1 && read_passphrase("again: ") != passphrase)
    throw Error("the two passphrases differ");
  std::printf("%s\n", training::hash_passphrase(passphrase, iterations).c_str());
  return 0;
}

int check_command(const std::string& file) {
  // The course, then its study (a study file's own errors are located in that file).
  const training::Course c = training::load_course(file);
  const training::Study study = training::load_study(c.study);
  std::printf("ok: %s (%s)\n", c.name.c_str(), file.c_str());
  std::printf("  study    %s%s: %s, %d trials\n", c.study.c_str(),
              c.study_is_file ? " (file)" : " (built-in)",
              std::string(training::study_kind_name(study.kind)).c_str(), study.trials);
  std::printf("  station  %s, study database %s\n", c.station.c_str(), c.database().string().c_str());
  // A fixed seed in a study file the station can read rebuilds every case (docs/instructors.md).
  if (study.seed)
    std::printf(
        "  note: the study has a fixed seed: whoever reads its file can rebuild every case; leave "
        "`seed:` out for an assessed class\n");
  // An exam seed: everyone the same cases, rebuilt by whoever reads the course file.
  if (c.exam_seed)
    std::printf(
        "  exam seed: every participant gets the same cases; whoever reads this file can rebuild them\n");
  else
    std::printf("  cases: each participant their own\n");
  if (c.participants.empty())
    std::printf("  participants: any ID\n");
  else
    std::printf("  participants: %zu listed\n", c.participants.size());
  std::printf("  instructor passphrase: PBKDF2-HMAC-SHA256, %d iterations\n",
              training::parse_passphrase_hash(c.instructor_hash).iterations);
  return 0;
}

int prepare_command(const std::string& file, std::optional<uint64_t> seed, int trials) {
  // The course's study and its trials as a station's run makes them (make_trial from each trial's
  // seed); each distinct scene is built with every part going into the tree cache, so that a trial's
  // build at the station loads it instead of building it: the exam's cases (exam_seed), or each listed
  // participant's own (a seed: --seed or the study's). Otherwise a trial whose scene its seed draws is
  // not known before the run: only the trials whose scene two seeds agree on (a case list's) are built.
  const training::Course c = training::load_course(file);
  training::Study study;
  try {
    study = training::load_study(c.study);
  } catch (const Error& e) {
    throw Error(file + ": study '" + c.study + "': " + e.what());
  }
  // Whose trials: an exam's seed gives every participant the same; otherwise each listed participant
  // has a stream of their own (participant_seed, as the run draws it); with neither a seed nor a list
  // of participants the drawn cases are not known before the run.
  std::vector<uint64_t> streams;
  if (c.exam_seed) {
    streams.push_back(seed.value_or(*c.exam_seed));
  } else if (!seed) {
    seed = study.seed;
  }
  if (!c.exam_seed && seed)
    for (const std::string& p : c.participants) streams.push_back(training::participant_seed(*seed, p));
  const int count = trials > 0 ? trials : study.trials;
  BuildOptions options;
  options.cache_lesion_parts = true;
  std::set<std::string> built;
  int prepared = 0, drawn = 0;
  for (int i = 0; i < count; ++i) {
    std::vector<training::TrialSetup> setups;
    for (const uint64_t s : streams) setups.push_back(training::make_trial(study, i, training::trial_seed(s, i)));
    if (streams.empty()) {
      training::TrialSetup setup = training::make_trial(study, i, training::trial_seed(1, i));
      const training::TrialSetup other = training::make_trial(study, i, training::trial_seed(2, i));
      if (other.scene_yaml != setup.scene_yaml) {
        std::printf("trial %d of %d: drawn from the run's seed, not prepared\n", i + 1, count);
        ++drawn;
        continue;
      }
      setups.push_back(std::move(setup));
    }
    for (const training::TrialSetup& setup : setups) {
      if (!built.insert(setup.scene_origin + "\n" + setup.scene_yaml).second) {
        std::printf("trial %d of %d: the scene of an earlier trial\n", i + 1, count);
        continue;
      }
      const auto start = std::chrono::steady_clock::now();
      BuildReport report;
      (void)build_model(setup.scene(), options, &report);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::printf("trial %d of %d: built into the tree cache (%.1f s)\n", i + 1, count, seconds);
      std::fflush(stdout);
      ++prepared;
    }
  }
  std::printf("prepared %d scene%s for %d trials in %s\n", prepared, prepared == 1 ? "" : "s", count,
              TreeCache::default_dir().string().c_str());
  if (drawn > 0)
    std::printf(
        "note: %d trials draw their case from the run's seed; give the course an exam_seed, or the study "
        "a seed (or --seed, the same as `cariesim run --seed`) and the course its participants, to "
        "prepare them\n",
        drawn);
  std::printf(
      "note: the cache now holds these cases' lesions: keep it where trainees cannot read it "
      "(docs/instructors.md, \"Keep the cases from the trainee\")\n");
  return 0;
}

}  // namespace

void register_course(CLI::App& app, Registry& registry) {
  auto* course = app.add_subcommand("course", "Course files: the instructor passphrase's hash, checks");
  course->require_subcommand(1);

  auto* hash = course->add_subcommand(
      "hash", "Hash the instructor passphrase read from standard input, for a course file's `instructor`");
  auto iterations = std::make_shared<int>(training::kPassphraseIterations);
  hash->add_option("--iterations", *iterations, "PBKDF2 iterations")
      ->check(CLI::Range(training::kPassphraseMinIterations, training::kPassphraseMaxIterations))
      ->capture_default_str();
  registry.add(hash, [iterations] { return hash_command(*iterations); });

  auto* check = course->add_subcommand("check", "Validate a course file");
  auto file = std::make_shared<std::string>();
  check->add_option("file", *file, "the course YAML file")->required();
  registry.add(check, [file] { return check_command(*file); });

  auto* prepare = course->add_subcommand(
      "prepare", "Build every case of a course's study into the tree cache before class");
  auto prepare_file = std::make_shared<std::string>();
  auto prepare_seed = std::make_shared<std::optional<uint64_t>>();
  auto prepare_trials = std::make_shared<int>(0);
  prepare->add_option("file", *prepare_file, "the course YAML file")->required();
  add_seed_option(prepare, *prepare_seed, "study seed the stations run with (default: the study's)");
  prepare
      ->add_option("--trials", *prepare_trials,
                   "Override the study's trial count (as `cariesim run --trials`)")
      ->check(CLI::PositiveNumber);
  registry.add(prepare, [prepare_file, prepare_seed, prepare_trials] {
    return prepare_command(*prepare_file, *prepare_seed, *prepare_trials);
  });
}

}  // namespace cariesim::cli
