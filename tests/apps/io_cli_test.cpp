// Issue 26, through the cariesim binary (CARIESIM_EXE): the figure step starts python3 without a
// shell and says why figures are missing (item 2, item 13), logs go to stderr (item 14), a FIFO as a
// mesh is named by its kind (item 13), and a killed report's staging folder is cleaned (item 21).
// Each test names the item it keeps fixed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "apps/apps_support.hpp"
#include "support/command.hpp"
#include "support/fifo.hpp"
#include "support/files.hpp"
#include "training/study_db_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

using test::cube_stl;
using test::shell_word;

bool have_matplotlib() { return test::python3_imports("matplotlib"); }

class IoCli : public test::ScratchTest {
 protected:
  IoCli() : ScratchTest("cariesim_io_cli_") {}

  // One station's study database with two tuning trials of P1: enough for the tuning figure.
  fs::path station() const {
    const fs::path db = dir_ / "station-a.db";
    test::StudyDbWriter a(db, "station-a");
    a.trial("P1", "tuning", "tuning", 1, "2026-11-20T09:00:00Z", "2026-11-20T09:05:00Z",
            {{"mu_s", "mild", 0.1, ""}, {"mu_s", "severe", 0.5, ""}});
    a.trial("P1", "tuning", "tuning", 2, "2026-11-20T09:05:00Z", "2026-11-20T09:10:00Z",
            {{"mu_s", "mild", 0.2, ""}, {"mu_s", "severe", 0.7, ""}});
    return db;
  }

  // Runs `cariesim ARGS` in the scratch folder (so a command an injection ran would write there), with
  // `env`'s "NAME=value" words added to its environment.
  test::CommandResult run(const std::string& args, const std::string& env = "") const {
    return test::run_cariesim(args, env, dir_);
  }

  // A python package folder whose `matplotlib` raises `exception` on import (PYTHONPATH puts it
  // before Debian's): a figure script that fails, or a python3 without matplotlib.
  std::string broken_matplotlib(const std::string& exception) const {
    const fs::path package = dir_ / "pythonpath" / "matplotlib";
    fs::create_directories(package);
    std::ofstream(package / "__init__.py") << "raise " << exception << "\n";
    return "PYTHONPATH=" + shell_word((dir_ / "pythonpath").string());
  }
};

// Item 2: the figure step built a shell command line from the output folder: `--out
// "out/r';id>pwned.txt;'"` ran `id` (pwned.txt appeared in the working folder) and lost the
// figures. The script now starts from an argument vector: no file appears, the figures are drawn.
TEST_F(IoCli, AnOutputPathWithQuotesAndSemicolonsRunsNothingAndGetsItsFigures) {
  const fs::path db = station();
  const std::string out = "out/r';id>pwned.txt;'";
  const test::CommandResult r = run("report " + shell_word(db.string()) + " --out " + shell_word(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "pwned.txt")) << "the output path ran a command";
  EXPECT_FALSE(fs::exists(dir_ / "out" / "pwned.txt")) << "the output path ran a command";
  EXPECT_TRUE(fs::exists(dir_ / out / "report.html"));
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing: figures not checked";
  EXPECT_TRUE(fs::exists(dir_ / out / "report-tuning.png")) << r.err;
  EXPECT_THAT(r.err, HasSubstr("(1 figure(s))"));
}

// Item 2: `--out "O'Brien class"` silently lost the figures and blamed matplotlib.
TEST_F(IoCli, AnApostropheInTheOutputFolderKeepsTheFigures) {
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing";
  const fs::path db = station();
  const test::CommandResult r = run("report " + shell_word(db.string()) + " --out " + shell_word("O'Brien class"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, Not(HasSubstr("matplotlib")));
  EXPECT_TRUE(fs::exists(dir_ / "O'Brien class" / "report-tuning.png")) << r.err;
}

// Item 13: every figure failure said "python3 with matplotlib needed". A script that fails for
// another reason is reported with its exit status and its stderr, and matplotlib is not blamed.
TEST_F(IoCli, AFailingFigureScriptReportsItsStatusAndStderr) {
  const fs::path db = station();
  const test::CommandResult r = run("report " + shell_word(db.string()) + " --out report",
                                    broken_matplotlib("RuntimeError('broken on purpose by the test')"));
  ASSERT_EQ(r.status, 0) << r.err;  // the data are written without figures
  EXPECT_THAT(r.err, HasSubstr("figures not drawn: the script exited with status 1; its stderr:"));
  EXPECT_THAT(r.err, HasSubstr("RuntimeError: broken on purpose by the test"));
  EXPECT_THAT(r.err, Not(HasSubstr("matplotlib needed")));
  EXPECT_THAT(r.err, Not(HasSubstr("has no matplotlib")));
  EXPECT_TRUE(fs::exists(dir_ / "report" / "report.html"));
  EXPECT_FALSE(fs::exists(dir_ / "report" / "report-tuning.png"));
}

// Item 13: a python3 whose `import matplotlib` fails with ModuleNotFoundError is reported as such.
TEST_F(IoCli, AMissingMatplotlibIsReportedAsSuch) {
  const fs::path db = station();
  const test::CommandResult r =
      run("report " + shell_word(db.string()) + " --out report --quiet",
          broken_matplotlib("ModuleNotFoundError(\"No module named 'matplotlib'\", name='matplotlib')"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(
      r.err, HasSubstr("figures not drawn: /usr/bin/python3 has no matplotlib (install python3-matplotlib)"));
  EXPECT_THAT(r.err, HasSubstr("ModuleNotFoundError: No module named 'matplotlib'"));
}

// Item 14: log lines went to stdout, so `tree --json` printed "[warning] tree cache: ..." before its
// JSON. Every log goes to stderr; stdout is the JSON alone.
TEST_F(IoCli, TreeJsonStaysJsonWhenTheCacheWarns) {
  const fs::path mesh = dir_ / "cube.stl";
  std::ofstream(mesh) << cube_stl(3.0);
  const std::string cache = "CARIESIM_CACHE_DIR=" + shell_word((dir_ / "cache").string()) + " ";
  const std::string args = "tree " + shell_word(mesh.string()) + " --json --quiet --tolerance 0.05";
  ASSERT_EQ(run(args, cache).status, 0);
  // Damage every cache entry: the next run warns that it ignores them, and rebuilds.
  int damaged = 0;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir_ / "cache"))
    if (e.is_regular_file() && e.path().extension() == ".tree") {
      std::ofstream(e.path(), std::ios::binary | std::ios::trunc) << "not a tree";
      ++damaged;
    }
  ASSERT_GT(damaged, 0);
  const test::CommandResult r = run(args, cache);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("tree cache: ignoring unreadable entry"));
  EXPECT_THAT(r.out, Not(HasSubstr("tree cache")));
  ASSERT_FALSE(r.out.empty());
  EXPECT_EQ(r.out.front(), '{') << r.out;
  const fs::path json = dir_ / "tree.json";
  std::ofstream(json) << r.out;
  const test::CommandOutput check =
      test::run_command({"/usr/bin/python3", "-c", "import json,sys; json.load(open(sys.argv[1]))", json.string()});
  EXPECT_EQ(check.status, 0) << check.err << r.out;
}

// Item 13: `cariesim tree FIFO` said "no such mesh file"; a FIFO is now named by its kind, at once.
TEST_F(IoCli, TreeOnAFifoNamesItsKind) {
  const fs::path fifo = dir_ / "tooth.stl";
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::CommandResult r = run("tree " + shell_word(fifo.string()) + " --quiet --no-cache");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr(fifo.string() + ": mesh: not a regular file (a FIFO (named pipe))"));
}

// Item 21: a killed `report` left `.DIR.report-PID` beside its output forever. The next run removes
// the staging folders of processes that no longer exist (and nothing else).
TEST_F(IoCli, AKilledReportsStagingFolderIsCleanedByTheNextRun) {
  const fs::path db = station();
  const pid_t gone = ::fork();
  if (gone == 0) ::_exit(0);
  ::waitpid(gone, nullptr, 0);
  const fs::path stale = dir_ / (".report.report-" + std::to_string(gone));
  const fs::path live = dir_ / (".report.report-" + std::to_string(::getpid()));
  for (const fs::path& p : {stale, live}) {
    fs::create_directories(p);
    std::ofstream(p / "table1_roughness.csv") << "participant\n";
  }
  const test::CommandResult r = run("report " + shell_word(db.string()) + " --out report --no-figures");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(stale)) << "a dead run's staging folder was left";
  EXPECT_TRUE(fs::exists(live / "table1_roughness.csv")) << "a live process's staging folder was removed";
  EXPECT_TRUE(fs::exists(dir_ / "report" / "report.html"));
}

}  // namespace
}  // namespace cariesim
