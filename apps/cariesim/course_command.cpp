// `cariesim course hash` and `cariesim course check FILE` (docs/instructors.md): the instructor's
// passphrase hash for a course file, read from standard input (asked twice, without echo, at a
// terminal), and a course file's check.
#include <fmt/format.h>
#include <termios.h>
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "cariesim/common/error.hpp"
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
}

}  // namespace cariesim::cli
