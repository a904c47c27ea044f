// `cariesim run --device fd` under Xvfb with the stand-in Force Dimension SDK (tests/device/standins/fd/,
// loaded through CARIESIM_FD_LIBRARY), its hand circling: the window runs the device for a second and
// exits cleanly, its status file naming the device.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "viewer/viewer_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using cariesim::test::have_xvfb;
using cariesim::test::json_query;
using cariesim::test::run_under_xvfb;
using cariesim::test::viewer_artefacts;

TEST(FdXvfb, TheViewerRunsWithTheStandInDevice) {
  if (!have_xvfb())
    GTEST_SKIP() << "xvfb-run is not installed (Debian package xvfb; scripts/setup installs it)";
  ::setenv("CARIESIM_FD_LIBRARY", CARIESIM_STANDIN_FD, 1);
  ::setenv("CARIESIM_STANDIN_FD_HAND", "circle:5:1", 1);
  const fs::path png = viewer_artefacts() / "fd-run.png";
  fs::remove(png);
  const test::RunResult r =
      run_under_xvfb("run --scene friction-block --device fd --no-realtime --exit-after 1 --screenshot '" +
                         png.string() + "'",
                     "fd-run");
  ::unsetenv("CARIESIM_FD_LIBRARY");
  ::unsetenv("CARIESIM_STANDIN_FD_HAND");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(png));
  EXPECT_EQ(json_query(viewer_artefacts() / "fd-run.json", "d[\"device\"]"), "fd");
}

}  // namespace
}  // namespace cariesim
