// `cariesim device list` and `cariesim device check` (docs/devices.md) over the stand-in SDKs the
// tests build (tests/device/standins): the SDKs and devices found, what to install when none is;
// a check that opens, calibrates, streams poses and buttons and renders its spring; a bad profile
// named before anything opens.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "apps/apps_support.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// Points every backend at nothing real: the stand-ins given here, a Haply service nobody serves.
std::string sdks(const std::string& hd, const std::string& fd) {
  return "CARIESIM_HD_LIBRARY=" + hd + " CARIESIM_FD_LIBRARY=" + fd +
         " CARIESIM_HAPLY_URL=http://127.0.0.1:9,ws://127.0.0.1:9";
}

TEST(DeviceCommand, ListNamesTheSdksFoundAndTheirDevices) {
  const test::CommandResult r =
      test::run_cariesim("device list", sdks(CARIESIM_STANDIN_HD, CARIESIM_STANDIN_FD));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr(std::string("touch: ") + CARIESIM_STANDIN_HD + " (version 3.4"));
  EXPECT_THAT(r.out, HasSubstr("  Touch #"));
  EXPECT_THAT(r.out, HasSubstr("6-DoF in, 3-DoF out"));
  EXPECT_THAT(r.out, HasSubstr(std::string("fd: ") + CARIESIM_STANDIN_FD));
  EXPECT_THAT(r.out, HasSubstr("haply: Haply Inverse Service: not found"));
  EXPECT_THAT(r.out, HasSubstr("2 devices attached"));
}

TEST(DeviceCommand, ListSaysWhatWasTriedAndWhatToInstallWhenNothingIsThere) {
  const test::CommandResult r =
      test::run_cariesim("device list", sdks("/nonexistent/libHD.so", "/nonexistent/libdrd.so.3"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("touch: OpenHaptics HD: not found (tried /nonexistent/libHD.so"));
  EXPECT_THAT(r.out, HasSubstr("CARIESIM_HD_LIBRARY is set to '/nonexistent/libHD.so'"));
  EXPECT_THAT(r.out, HasSubstr("install: install 3D Systems' OpenHaptics"));
  EXPECT_THAT(r.out, HasSubstr("fd: Force Dimension SDK: not found"));
  EXPECT_THAT(r.out, HasSubstr("0 devices attached"));
}

TEST(DeviceCommand, CheckStreamsPosesAndButtonsAndRendersTheSpring) {
  const test::CommandResult r = test::run_cariesim(
      "device check touch --force --seconds 1.5",
      sdks(CARIESIM_STANDIN_HD, CARIESIM_STANDIN_FD) + " CARIESIM_STANDIN_HD=circle,buttons");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("device touch: Touch #"));
  EXPECT_THAT(r.out, HasSubstr("3-DoF force: the torque"));
  EXPECT_THAT(r.out, HasSubstr("calibration: "));
  EXPECT_THAT(r.out, HasSubstr("valid) in "));
  EXPECT_THAT(r.out, HasSubstr("buttons pressed: 0, 1"));
  EXPECT_THAT(r.out, Not(HasSubstr("reached 0.0 x 0.0 x 0.0")));  // the hand's circle was seen
  EXPECT_THAT(r.out, HasSubstr("force enabled"));
  EXPECT_THAT(r.out, Not(HasSubstr("spring: peak 0.000 N")));  // the spring pulled
}

TEST(DeviceCommand, CheckWithoutTheSdkFailsNamingIt) {
  const test::CommandResult r =
      test::run_cariesim("device check fd", sdks("/nonexistent/libHD.so", "/nonexistent/libdrd.so.3"));
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err,
              HasSubstr("device spec 'fd': Force Dimension SDK: not found (tried /nonexistent/libdrd.so.3"));
}

TEST(DeviceCommand, ABadProfileIsNamedBeforeTheDeviceOpens) {
  const auto file = std::filesystem::temp_directory_path() / "cariesim_bad_profile.yaml";
  std::ofstream(file) << "scale: 2\nbuttons: {0: grab}\n";
  const test::CommandResult r = test::run_cariesim("device check touch --device-profile " + file.string(),
                                                   sdks(CARIESIM_STANDIN_HD, CARIESIM_STANDIN_FD));
  std::filesystem::remove(file);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr(file.string() + ":2:"));
  EXPECT_THAT(r.err, HasSubstr("buttons.0"));
  EXPECT_THAT(r.out, Not(HasSubstr("device touch:")));
}

}  // namespace
}  // namespace cariesim
