// The example client (examples/udp_client.cpp) against an in-process UDP device and servo loop: the
// headless harness the bridge documentation mentions.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "cariesim/device/udp_device.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"
#include "support/command.hpp"

namespace cariesim {
namespace {

TEST(UdpExampleClient, StreamsATrajectoryAndGetsWrenches) {
#ifndef CARIESIM_UDP_CLIENT
  GTEST_SKIP() << "the example client is not built (examples/ not configured)";
#else
  Model model = test::friction_block();
  UdpOptions udp;
  udp.port = 0;
  udp.home = model.tool_home;
  udp.timeout = 0.5;  // s: no scheduling stall of a loaded test machine makes a pose stale
  UdpDevice device(udp);
  ServoOptions o;
  o.realtime = false;
  ServoLoop loop(model, device, o);
  loop.start();

  const auto csv = std::filesystem::temp_directory_path() / "cariesim_udp_client_test.csv";
  save_trajectory_csv(test::press_and_slide(model, 1.0, 0.5), csv);
  const test::CommandOutput client =
      test::run_command({CARIESIM_UDP_CLIENT, csv.string(), "--port", std::to_string(device.port()),
                         "--print-every", "0.2", "--velocity"});
  const std::string output = client.out + client.err;
  const int status = client.status;
  loop.stop();
  std::filesystem::remove(csv);

  // It exits 0 only when wrenches came back; the device saw its hello and its poses.
  EXPECT_EQ(status, 0) << output;
  EXPECT_NE(output.find("received"), std::string::npos) << output;
  EXPECT_NE(output.find("sliding"), std::string::npos) << output;  // it pressed on the block
  const BridgeCounters c = device.bridge_counters();
  EXPECT_EQ(c[BridgeVerdict::AcceptedHello], 1u);
  EXPECT_GT(c[BridgeVerdict::AcceptedPose], 100u);
  EXPECT_EQ(c.rejected(), 0u);
  EXPECT_NE(device.info().description.find("cariesim_udp_client"), std::string::npos);
#endif
}

}  // namespace
}  // namespace cariesim
