// `cariesim run --device touch` under Xvfb over the stand-in libHD.so (tests/device/standins/hd), its
// hand tracing a circle: the viewer starts, the servo loop runs clocked by HD's scheduler and the
// window closes cleanly after --exit-after.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
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
  const fs::path png = test::viewer_artefacts() / "touch.png", json = test::viewer_artefacts() / "touch.json";
  fs::remove(json);
  argv.emplace_back("--screenshot");
  argv.emplace_back(png.string());
  io::ProcessOptions options;
  options.environment = {"CARIESIM_CACHE_DIR=" + (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string(),
                         std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD,
                         "CARIESIM_STANDIN_HD=circle"};
  const test::CommandOutput c = test::run_command(argv, options);
  std::ofstream(test::viewer_artefacts() / "touch-run.log", std::ios::binary) << c.out << c.err;
  ASSERT_EQ(c.status, 0) << c.how << "\n" << c.err << c.out;
  EXPECT_THAT(c.out, HasSubstr("run: scene friction-block, device touch, 1000 Hz servo"));
  EXPECT_THAT(c.out, HasSubstr("real-time: clocked by the device's scheduler at 1000 Hz"));
  // The panel's Device section and the status file: the device, its calibration, its force, and
  // what a 3-DoF-force device drops.
  std::ifstream in(json);
  ASSERT_TRUE(in) << json;
  const std::string status((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(status, HasSubstr("\"Device\""));
  EXPECT_THAT(status, HasSubstr("\"hardware\":{\"model\":\"Touch\",\"calibrated\":true"));
  EXPECT_THAT(status, HasSubstr("\"force_was_enabled\":true"));  // the file is written after the stop
  EXPECT_THAT(status, HasSubstr("\"clutch\":false"));
  EXPECT_THAT(
      status,
      HasSubstr("\"rendering\":\"3-DoF force: the torque (the shank's posture cue) is not rendered\""));
}

// The Touch unplugged mid-run in the window: the panel's Device section and the status file say the
// device was lost, and no force reached it after that.
TEST(TouchXvfb, AnUnpluggedTouchIsShownLost) {
  if (!test::have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  std::vector<std::string> argv = test::xvfb_cariesim();
  const fs::path png = test::viewer_artefacts() / "touch-lost.png",
                 json = test::viewer_artefacts() / "touch-lost.json";
  fs::remove(json);
  for (const std::string& word :
       {std::string("run"), std::string("--scene"), std::string("friction-block"), std::string("--device"),
        std::string("touch"), std::string("--no-realtime"), std::string("--exit-after"), std::string("2"),
        std::string("--screenshot"), png.string()})
    argv.push_back(word);
  io::ProcessOptions options;
  options.environment = {"CARIESIM_CACHE_DIR=" + (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string(),
                         std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD,
                         "CARIESIM_STANDIN_HD=circle,unplug-at-0.5s"};
  const test::CommandOutput c = test::run_command(argv, options);
  ASSERT_EQ(c.status, 0) << c.how << "\n" << c.err << c.out;
  std::ifstream in(json);
  ASSERT_TRUE(in) << json;
  const std::string status((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(status, HasSubstr("\"faults\":\"device lost\"")) << status;
}

}  // namespace
}  // namespace cariesim
