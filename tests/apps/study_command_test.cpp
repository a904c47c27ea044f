// `cariesim study` (apps/cariesim/study_command.cpp): the examples of docs/cli.md run as written
// (from the repository's root, the database in a scratch folder), and the command's errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "apps/apps_support.hpp"
#include "support/command.hpp"
#include "support/files.hpp"

namespace cariesim::test {
namespace {

namespace fs = std::filesystem;

class StudyCommand : public ScratchTest {
 protected:
  StudyCommand() : ScratchTest("cariesim_study_") {}
};

// Runs `command` (a line starting with "cariesim") from the repository's root, with `--out class.db`
// pointed into `dir`; returns the exit status, the output (stdout then stderr) in `out`.
int run_example(std::string command, const fs::path& dir, std::string& out) {
  const std::string db = " --out class.db";
  if (const std::size_t at = command.find(db); at != std::string::npos)
    command.replace(at, db.size(), " --out " + cariesim::test::shell_word((dir / "class.db").string()));
  std::vector<std::string> argv = cariesim::test::words(command);
  argv.front() = CARIESIM_EXE;
  cariesim::io::ProcessOptions options;
  options.working_dir = CARIESIM_SOURCE_DIR;
  const cariesim::test::CommandOutput r = cariesim::test::run_command(argv, options);
  out = r.out + r.err;
  return r.status;
}

TEST_F(StudyCommand, TheDocExamplesRunAndFillOneDatabase) {
  const std::vector<std::string> examples =
      cariesim::test::doc_commands(read_text(fs::path(CARIESIM_SOURCE_DIR) / "docs" / "cli.md"),
                                   "## `cariesim study", "cariesim study");
  ASSERT_EQ(examples.size(), 5u) << "docs/cli.md has the `cariesim study` example block";
  for (const std::string& command : examples) {
    SCOPED_TRACE(command);
    std::string out;
    EXPECT_EQ(run_example(command, dir_, out), 0) << out;
    if (command.find("study list") != std::string::npos) {
      EXPECT_NE(out.find("boundary-shapes"), std::string::npos);
    }
    if (command.find("study check") != std::string::npos) {
      EXPECT_NE(out.find("ok: diagnosis"), std::string::npos);
    }
  }
  // Two boundary trials (both right), two tuning trials and one diagnosis case, with their recordings.
  ASSERT_TRUE(fs::exists(dir_ / "class.db"));
  std::size_t recordings = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "class-recordings"))
    recordings += entry.path().extension() == ".db" ? 1 : 0;
  EXPECT_EQ(recordings, 5u);
}

TEST_F(StudyCommand, ErrorsNameTheFileAndPlace) {
  // A study file with an unknown key.
  const fs::path study = dir_ / "bad.yaml";
  std::ofstream(study) << "kind: boundary-shapes\nboundary:\n  cubes: [1, 2, 3]\n";
  CommandResult r = run_cariesim("study check '" + study.string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("bad.yaml:3:3"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cubes"), std::string::npos) << r.err;
  // Answers that do not fit the trial.
  const fs::path answers = dir_ / "answers.yaml";
  std::ofstream(answers) << "trials:\n  - shapes: [square]\n";
  r = run_cariesim("study run '" +
                       (fs::path(CARIESIM_SOURCE_DIR) / "studies/examples/boundary-small.yaml").string() +
                       "' --participant P01 --answers '" + answers.string() + "' --out '" +
                       (dir_ / "x.db").string() + "' --duration 0.05 --quiet");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("answers.yaml:2:5"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 shapes named for 3 cubes"), std::string::npos) << r.err;
  // A participant id with a space.
  r = run_cariesim("study run boundary-shapes --participant 'P 1' --answers '" + answers.string() +
                       "' --out '" + (dir_ / "y.db").string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("participant 'P 1'"), std::string::npos) << r.err;
  // A study name that would take the recordings out of their folder (`study check` accepted it).
  for (const std::string name : {"../../../../tmp/x", "/tmp/x"}) {
    std::ofstream(dir_ / "escape.yaml") << "name: " << name << "\nkind: boundary-shapes\n";
    r = run_cariesim("study check '" + (dir_ / "escape.yaml").string() + "'");
    EXPECT_EQ(r.status, 2) << name;
    EXPECT_NE(r.err.find("escape.yaml:1:7: name: '" + name + "' is not a valid study name"),
              std::string::npos)
        << r.err;
  }
}

// `--seed -1` and `--seed 99999999999999999999` became 2^64 - 1 without a word (CLI11 wraps them):
// every --seed is refused unless it is a seed in [0, 2^63 - 1], naming the option, before anything runs.
TEST_F(StudyCommand, SeedsOutOfRangeAreRefusedEverywhere) {
  const fs::path answers = dir_ / "answers.yaml";
  std::ofstream(answers) << "trials:\n  - shapes: [square, circle, triangle]\n";
  std::ofstream(dir_ / "course.yaml")
      << "course: C\nstudy: boundary-shapes\nrecords: records\nstation: s1\ninstructor: "
         "pbkdf2-sha256$100000$000102030405060708090a0b0c0d0e0f$"
         "c8d122ecdb9477cd48a6b1750c5985c0b8b05158d040d20517ccdb49865de436\n";
  for (const std::string seed :
       {"-1", "99999999999999999999", "18446744073709551615", "9223372036854775808", "0x10", "1e3"}) {
    SCOPED_TRACE(seed);
    CommandResult r = run_cariesim(
        "study run '" + (fs::path(CARIESIM_SOURCE_DIR) / "studies/examples/boundary-small.yaml").string() +
            "' --participant P01 --answers '" + answers.string() + "' --out '" + (dir_ / "s.db").string() +
            "' --seed " + seed);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is not a seed"), std::string::npos) << r.err;
    r = run_cariesim(
        "run --course '" + (dir_ / "course.yaml").string() + "' --participant P01 --seed " + seed);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is not a seed"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "s.db")) << "nothing ran";
  EXPECT_FALSE(fs::exists(dir_ / "records")) << "no station started";
}

}  // namespace
}  // namespace cariesim::test
