// The `cariesim run` examples of docs/cli.md run as written: each command line of the section's
// example block runs under Xvfb from a scratch folder that sees the repository's scenes/, in order
// (the replay example plays the record the example before it wrote). An example without
// --exit-after gets `--exit-after 0.5` so that it ends; UDP examples are left out (their port may be
// taken by another test on the machine).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "support/files.hpp"
#include "viewer/viewer_support.hpp"

namespace {

namespace fs = std::filesystem;

using cariesim::test::read_text;

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

TEST(CliDoc, RunExamplesRun) {
  if (!cariesim::test::have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
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
    const cariesim::test::RunResult r =
        cariesim::test::run_under_xvfb(args, "cli-doc-example-" + std::to_string(ran), dir);
    EXPECT_EQ(r.status, 0) << command << "\n" << r.out << r.err;
    EXPECT_THAT(r.out + r.err, ::testing::HasSubstr("servo:")) << command;
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
