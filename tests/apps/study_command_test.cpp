// `cariesim study` (apps/cariesim/study_command.cpp): the examples of docs/cli.md run as written
// (from the repository's root, the database in a scratch folder), and the command's errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "apps/apps_support.hpp"
#include "cariesim/training/study.hpp"
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

// The trial seeds a run printed ("study: trial N/M (seed S): ..."), in order.
std::vector<std::string> printed_seeds(const std::string& err) {
  std::vector<std::string> seeds;
  for (std::size_t at = err.find("(seed "); at != std::string::npos; at = err.find("(seed ", at + 1))
    seeds.push_back(err.substr(at + 6, err.find(')', at) - at - 6));
  return seeds;
}

// Two participants of one study seed get different drawn cases (each trial's seed depends on the
// participant; coarse trees keep the builds short); with --same-cases (a course's exam_seed) both get
// the seed's own trials. Before, the
// trials depended on the seed alone, so every trainee of a class with a fixed seed had the same cases.
TEST_F(StudyCommand, EachParticipantGetsCasesOfTheirOwnUnlessTheCasesAreShared) {
  const fs::path examples = fs::path(CARIESIM_SOURCE_DIR) / "studies/examples";
  std::map<std::string, std::vector<std::string>> seeds;
  for (const std::string participant : {"P01", "P02"}) {
    for (const std::string same : {"", " --same-cases"}) {
      const CommandResult r =
          run_cariesim("study run '" + (examples / "diagnosis-drawn.yaml").string() + "' --participant " +
                       participant + " --answers '" + (examples / "diagnosis-drawn-answers.yaml").string() +
                       "' --out '" + (dir_ / "class.db").string() +
                       "' --seed 5 --trials 1 --set 'objects[0].tree.tolerance=0.2'" + same);
      ASSERT_EQ(r.status, 0) << r.err;
      seeds[participant + same] = printed_seeds(r.err);
      ASSERT_EQ(seeds[participant + same].size(), 1u) << r.err;
    }
  }
  EXPECT_NE(seeds["P01"], seeds["P02"]);
  EXPECT_EQ(seeds["P01 --same-cases"], seeds["P02 --same-cases"]);
  EXPECT_EQ(seeds["P01 --same-cases"][0], std::to_string(cariesim::training::trial_seed(5, 0)));
  EXPECT_EQ(seeds["P01"][0], std::to_string(cariesim::training::trial_seed(
                                 cariesim::training::participant_seed(5, "P01"), 0)));
}

// A course's exam_seed: `course check` says every participant gets the same cases; a bad one is
// refused at its line and column, naming the field.
TEST_F(StudyCommand, CourseCheckSaysWhetherTheCasesAreShared) {
  const std::string head = "course: C\nstudy: diagnosis\nrecords: records\nstation: s1\n";
  const std::string hash =
      "instructor: pbkdf2-sha256$100000$000102030405060708090a0b0c0d0e0f$"
      "c8d122ecdb9477cd48a6b1750c5985c0b8b05158d040d20517ccdb49865de436\n";
  std::ofstream(dir_ / "class.yaml") << head << hash;
  std::ofstream(dir_ / "exam.yaml") << head << "exam_seed: 20261126\n" << hash;
  std::ofstream(dir_ / "bad.yaml") << head << "exam_seed: -3\n" << hash;
  CommandResult r = run_cariesim("course check '" + (dir_ / "class.yaml").string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("cases: each participant their own"), std::string::npos) << r.out;
  r = run_cariesim("course check '" + (dir_ / "exam.yaml").string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("exam seed: every participant gets the same cases"), std::string::npos) << r.out;
  r = run_cariesim("course check '" + (dir_ / "bad.yaml").string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("bad.yaml:5:12: exam_seed: expected a seed"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace cariesim::test
