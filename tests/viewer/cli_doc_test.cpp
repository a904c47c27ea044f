// The `cariesim run` examples of docs/cli.md run as written: each command line of the section's
// example block runs under Xvfb from a scratch folder that sees the repository's scenes/, in order
// (the replay example plays the record the example before it wrote). An example without
// --exit-after gets `--exit-after 0.5` so that it ends; UDP examples are left out (their port may be
// taken by another test on the machine).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "support/files.hpp"

namespace {

namespace fs = std::filesystem;

using cariesim::test::read_text;

int shell(const std::string& command) {
  const int raw = std::system(command.c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

TEST(CliDoc, RunExamplesRun) {
  if (shell("command -v xvfb-run >/dev/null 2>&1") != 0) GTEST_SKIP() << "xvfb-run is not installed";
  const std::vector<std::string> examples =
      cariesim::test::doc_commands(read_text(fs::path(CARIESIM_SOURCE_DIR) / "docs" / "cli.md"),
                                   "## `cariesim run", "cariesim");
  ASSERT_GE(examples.size(), 4U) << "docs/cli.md has the `cariesim run` example block";

  // A scratch folder with the repository's scenes/ (the examples' relative paths).
  const fs::path dir = fs::path(CARIESIM_BINARY_DIR) / "test-artifacts" / "cli-doc";
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::create_directory_symlink(fs::path(CARIESIM_SOURCE_DIR) / "scenes", dir / "scenes");

  int ran = 0;
  for (std::string command : examples) {
    if (contains(command, "udp:")) continue;
    // `cariesim` alone is `cariesim run`; every example ends by itself.
    std::string args = command.substr(std::string("cariesim").size());
    if (!contains(args, " run")) args = " run" + args;
    if (!contains(args, "--exit-after")) args += " --exit-after 0.5";
    const fs::path log = dir / ("example-" + std::to_string(ran) + ".log");
    const int status = shell("cd '" + dir.string() + "' && CARIESIM_CACHE_DIR='" +
                             (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string() +
                             "' timeout 900 xvfb-run -a -s '-screen 0 1280x800x24' '" + CARIESIM_EXE + "'" +
                             args + " >'" + log.string() + "' 2>&1");
    EXPECT_EQ(status, 0) << command << "\n" << read_text(log);
    EXPECT_THAT(read_text(log), ::testing::HasSubstr("servo:")) << command;
    // What the example says it writes is there.
    std::istringstream words(args);
    std::string word, previous;
    while (words >> word) {
      if (previous == "--record" || previous == "--screenshot") {
        EXPECT_TRUE(fs::exists(dir / word)) << command;
      }
      previous = word;
    }
    ++ran;
  }
  EXPECT_GE(ran, 4);
}

}  // namespace
