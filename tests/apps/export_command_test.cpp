// `cariesim export FILE --out DIR` on a recording made through the library, and on bad input.
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
#include "cariesim/record/recorder.hpp"
#include "support/files.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

using cariesim::test::read_text;

// Runs `cariesim ARGS`; returns the exit status and stderr.
int run_cariesim(const std::string& args, std::string& err) {
  const test::CommandResult r = test::run_cariesim(args);
  err = r.err;
  return r.status;
}

TEST(ExportCommand, WritesTheCsvFiles) {
  const fs::path dir = fs::temp_directory_path() / ("cariesim_export_cmd_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path file = dir / "session.db";
  {
    SessionInfo info;
    info.scene = "friction-block";
    Recorder recorder(file, info);
    for (int i = 0; i < 250; ++i) {
      ServoSample s;
      s.t = i * 0.001;
      s.haptic.p = Vec3(0.1 * i, 0, 1);
      s.state = i < 100 ? InteractionState::Free : InteractionState::Sliding;
      ASSERT_TRUE(recorder.queue().push(s));
    }
    recorder.stop();
  }
  std::string err;
  ASSERT_EQ(run_cariesim("export '" + file.string() + "' --out '" + (dir / "csv").string() + "'", err),
            0)
      << err;
  EXPECT_THAT(err, HasSubstr("250 samples"));
  for (const char* name : {"session.csv", "samples.csv", "events.csv", "trajectory.csv"})
    EXPECT_TRUE(fs::exists(dir / "csv" / name)) << name;
  const std::string events = read_text(dir / "csv" / "events.csv");
  EXPECT_THAT(events, HasSubstr("0.1,state,free->sliding,"));
  std::istringstream samples(read_text(dir / "csv" / "samples.csv"));
  int lines = 0;
  for (std::string line; std::getline(samples, line);) ++lines;
  EXPECT_EQ(lines, 251);

  // A file that is not a recording: exit status 2 and the file named.
  std::ofstream(dir / "notes.txt")
      << "not a recording at all, just some text long enough for SQLite to look at";
  EXPECT_EQ(run_cariesim("export '" + (dir / "notes.txt").string() + "' --out '" + (dir / "x").string() + "'", err),
            2);
  EXPECT_THAT(err, HasSubstr("notes.txt"));
  EXPECT_THAT(err, HasSubstr("not a cariesim recording"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cariesim
