// io/staged_folder.hpp: an output folder written all or nothing, and the staging folders a killed
// run left behind cleaned by the next run.
#include "cariesim/io/staged_folder.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;

// The id of a process that has ended (a child that exited at once and was reaped).
pid_t dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

class StagedFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-io-staged-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A folder with a file in it, like a killed run's staging folder.
  fs::path leftover(const std::string& name) {
    const fs::path p = dir_ / name;
    fs::create_directories(p);
    std::ofstream(p / "table.csv") << "a,b\n";
    return p;
  }
  fs::path dir_;
};

TEST_F(StagedFolderTest, PublishesIntoANewOrAnExistingFolder) {
  {
    StagedFolder staged(dir_ / "out", "report");
    EXPECT_EQ(staged.staging().filename().string(), ".out.report-" + std::to_string(::getpid()));
    std::ofstream(staged.staging() / "a.csv") << "1\n";
    EXPECT_EQ(staged.publish().size(), 1u);
  }
  EXPECT_TRUE(fs::exists(dir_ / "out" / "a.csv"));
  {
    StagedFolder staged(dir_ / "out", "report");
    std::ofstream(staged.staging() / "b.csv") << "2\n";
    staged.publish();
  }
  EXPECT_TRUE(fs::exists(dir_ / "out" / "a.csv"));
  EXPECT_TRUE(fs::exists(dir_ / "out" / "b.csv"));
  // Nothing staged is left.
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_EQ(e.path().filename(), "out");
}

// Issue 26 item 21: a killed `report` or `export` left `.DIR.report-PID` (18 MB) forever. The next
// run for the same target removes those of dead processes, and only those: not a live process's,
// not another target's or another command's, not a name that only looks alike, not a link.
TEST_F(StagedFolderTest, StaleStagingFoldersOfDeadProcessesAreRemoved) {
  const std::string dead = std::to_string(dead_pid());
  const fs::path stale = leftover(".out.report-" + dead);
  const fs::path live = leftover(".out.report-" + std::to_string(::getppid()));  // our parent runs
  const fs::path other_target = leftover(".other.report-" + dead);
  const fs::path other_command = leftover(".out.export-" + dead);
  const fs::path not_a_pid = leftover(".out.report-" + dead + "x");
  const fs::path leading_zero = leftover(".out.report-0" + dead);
  const fs::path target_of_link = leftover("keep");
  fs::create_directory_symlink(target_of_link, dir_ / (".out.report-" + std::to_string(dead_pid())));
  {
    StagedFolder staged(dir_ / "out", "report");
    ASSERT_EQ(staged.removed_stale().size(), 1u);
    EXPECT_EQ(staged.removed_stale()[0], stale);
  }
  EXPECT_FALSE(fs::exists(stale));
  for (const fs::path& kept : {live, other_target, other_command, not_a_pid, leading_zero, target_of_link})
    EXPECT_TRUE(fs::exists(kept / "table.csv")) << kept;
}

}  // namespace
}  // namespace cariesim::io
