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

// The command lines starting with `cariesim` in the first ```sh block after the `cariesim run`
// heading, without their trailing `# comments`.
std::vector<std::string> run_examples(const std::string& doc) {
  std::vector<std::string> commands;
  const std::size_t section = doc.find("## `cariesim run");
  if (section == std::string::npos) return commands;
  const std::size_t open = doc.find("```sh\n", section);
  if (open == std::string::npos) return commands;
  const std::size_t close = doc.find("```", open + 6);
  std::istringstream block(doc.substr(open + 6, close - open - 6));
  std::string line;
  while (std::getline(block, line)) {
    if (const std::size_t hash = line.find(" #"); hash != std::string::npos) line.erase(hash);
    while (!line.empty() && line.back() == ' ') line.pop_back();
    if (line.rfind("cariesim", 0) == 0) commands.push_back(line);
  }
  return commands;
}

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

TEST(CliDoc, RunExamplesRun) {
  if (shell("command -v xvfb-run >/dev/null 2>&1") != 0) GTEST_SKIP() << "xvfb-run is not installed";
  const std::vector<std::string> examples =
      run_examples(read_text(fs::path(CARIESIM_SOURCE_DIR) / "docs" / "cli.md"));
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
