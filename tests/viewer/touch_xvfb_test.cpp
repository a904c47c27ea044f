// `cariesim run --device touch` under Xvfb over the stand-in libHD.so (tests/device/standins/hd), its
// hand tracing a circle: the viewer starts, the servo loop runs clocked by HD's scheduler and the
// window closes cleanly after --exit-after.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "support/command.hpp"
#include "viewer_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(TouchXvfb, RunDrivesTheViewerFromTheStandin) {
  if (!test::have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  std::vector<std::string> argv = test::xvfb_cariesim();
  for (const char* word :
       {"run", "--scene", "friction-block", "--device", "touch", "--no-realtime", "--exit-after", "1"})
    argv.emplace_back(word);
  io::ProcessOptions options;
  options.environment = {"CARIESIM_CACHE_DIR=" + (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string(),
                         std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD,
                         "CARIESIM_STANDIN_HD=circle"};
  const test::CommandOutput c = test::run_command(argv, options);
  std::ofstream(test::viewer_artefacts() / "touch-run.log", std::ios::binary) << c.out << c.err;
  ASSERT_EQ(c.status, 0) << c.how << "\n" << c.err << c.out;
  EXPECT_THAT(c.out, HasSubstr("run: scene friction-block, device touch, 1000 Hz servo"));
  EXPECT_THAT(c.out, HasSubstr("real-time: clocked by the device's scheduler at 1000 Hz"));
}

}  // namespace
}  // namespace cariesim
