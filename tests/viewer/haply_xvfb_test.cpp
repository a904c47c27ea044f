// `cariesim run --device haply:URL` under Xvfb against the Inverse Service stand-in running in this
// test's process (tests/device/standins/haply): the viewer's servo loop exchanges with the service for
// the run, the status file names the device, and on exit the force is zero and the WebSocket closed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "standins/haply/inverse_service.hpp"
#include "support/files.hpp"
#include "viewer/viewer_support.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(HaplyXvfb, RunExchangesWithTheServiceAndSwitchesOff) {
  if (!test::have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (Debian package xvfb)";
  test::InverseService service;
  service.place_cursor(Vec3(0.0, 0.1, 0.1));  // m: the workspace centre, the tool home
  const fs::path png = test::viewer_artefacts() / "haply.png", json = test::viewer_artefacts() / "haply.json";
  fs::remove(png);
  fs::remove(json);
  const test::RunResult r =
      test::run_under_xvfb("run --scene friction-block --device 'haply:" + service.url() +
                               "' --no-realtime --exit-after 1.5 --screenshot '" + png.string() + "'",
                           "haply");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("step time (us): p50"));
  ASSERT_TRUE(fs::exists(json)) << r.err;
  EXPECT_THAT(test::read_text(json), HasSubstr("\"device\":\"haply:" + service.url() + "\""));
  EXPECT_GT(service.commands(), 1000u);
  EXPECT_EQ(service.last_force(), Vec3::Zero());
  EXPECT_EQ(service.open_connections(), 0);
}

}  // namespace
}  // namespace cariesim
