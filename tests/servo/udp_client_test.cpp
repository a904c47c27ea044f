// The example client (examples/udp_client.cpp) against an in-process UDP device and servo loop: the
// headless harness the bridge documentation mentions.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>

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
  EXPECT_GE(c[BridgeVerdict::AcceptedHello], 1u);  // again every 0.5 s until acknowledged
  EXPECT_GT(c[BridgeVerdict::AcceptedPose], 100u);
  EXPECT_EQ(c.rejected(), 0u);
  EXPECT_NE(device.info().description.find("cariesim_udp_client"), std::string::npos);
#endif
}

// A UDP port nobody listens on now (bound to port 0, read back, closed).
uint16_t free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t length = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length);
  ::close(fd);
  return ntohs(addr.sin_port);
}

TEST(UdpExampleClient, StartedBeforeTheSimulatorItsHelloIsStillAcknowledged) {
#ifndef CARIESIM_UDP_CLIENT
  GTEST_SKIP() << "the example client is not built (examples/ not configured)";
#else
  // The client streams for 4 s to a port where the simulator starts only after 1.5 s: its first
  // hellos reach nobody, a later one is acknowledged and the announced limits apply.
  Model model = test::friction_block();
  const uint16_t port = free_udp_port();
  const auto csv = std::filesystem::temp_directory_path() / "cariesim_udp_client_late_test.csv";
  save_trajectory_csv(test::press_and_slide(model, 1.0, 0.5), csv);
  test::CommandOutput client;
  std::thread run([&] {
    client = test::run_command({CARIESIM_UDP_CLIENT, csv.string(), "--port", std::to_string(port), "--loop",
                                "--duration", "4", "--print-every", "0.5", "--max-force", "3.3"});
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  UdpOptions udp;
  udp.port = port;
  udp.home = model.tool_home;
  udp.timeout = 0.5;
  UdpDevice device(udp);
  ServoOptions o;
  o.realtime = false;
  ServoLoop loop(model, device, o);
  loop.start();
  ASSERT_TRUE(test::wait_for([&] { return device.bridge_counters()[BridgeVerdict::AcceptedHello] > 0; }));
  PublishedParams params;
  const bool limited =
      test::wait_for([&] { return loop.latest_params(params) && params.params.limits.max_force == 3.3; });
  run.join();
  loop.stop();
  std::filesystem::remove(csv);
  const std::string output = client.out + client.err;
  EXPECT_TRUE(limited) << "the hello's 3.3 N never applied";
  EXPECT_EQ(client.status, 0) << output;
  EXPECT_NE(output.find("hello acknowledged"), std::string::npos) << output;
  EXPECT_NE(output.find("(acknowledged)"), std::string::npos) << output;
#endif
}

}  // namespace
}  // namespace cariesim
