// UdpDevice over loopback without a servo loop (the test thread plays the servo thread): a hello's
// limits come out of poll_limits once and as announced, the wrench goes out as given (the bridge
// clamps nothing; the servo loop's Params bound it), and the status travels with it.
#include "cariesim/device/udp_device.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "cariesim/common/clock.hpp"
#include "cariesim/device/safety.hpp"

namespace cariesim {
namespace {

// A UDP socket connected to the device's port.
class Client {
 public:
  explicit Client(uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd_, reinterpret_cast<sockaddr*>(&to), sizeof(to)), 0);
    timeval wait{0, 200000};  // 0.2 s per receive, so a missing answer fails instead of hanging
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof(wait));
  }
  ~Client() { ::close(fd_); }
  void send(const std::vector<uint8_t>& b) const {
    EXPECT_EQ(::send(fd_, b.data(), b.size(), 0), static_cast<ssize_t>(b.size()));
  }
  // The next wrench, false after the receive timeout.
  bool receive(bridge::WrenchPacket& w) const {
    uint8_t buffer[256];
    const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
    return n > 0 &&
           bridge::parse_wrench(buffer, static_cast<std::size_t>(n), w) == bridge::ParseResult::Wrench;
  }

 private:
  int fd_ = -1;
};

double now_s() { return static_cast<double>(monotonic_ns()) * 1e-9; }

std::vector<uint8_t> hello(uint32_t sequence) {
  bridge::HelloPacket h;
  h.sequence = sequence;
  h.client_time = now_s();
  h.max_force = 3.5;
  h.max_stiffness = 0.01;
  h.max_torque = 0.0;  // renders no torque
  h.workspace_min = Vec3(-80, -70, -60);
  h.workspace_max = Vec3(80, 70, 60);
  std::memcpy(h.name.data(), "test arm", 8);
  std::vector<uint8_t> b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_hello(h, b.data(), b.size()));
  return b;
}

std::vector<uint8_t> pose(uint32_t sequence) {
  bridge::PosePacket p;
  p.sequence = sequence;
  p.client_time = now_s();
  p.pose.p = Vec3(1, 2, 3);
  std::vector<uint8_t> b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_pose(p, b.data(), b.size()));
  return b;
}

// Polls `done` every millisecond for up to 10 s (only keeps a broken test from hanging).
template <typename F>
bool eventually(F done) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

TEST(UdpDevice, HelloLimitsArePolledOnceAsAnnounced) {
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  UdpDevice device(o);
  DeviceLimits limits;
  EXPECT_FALSE(device.poll_limits(limits));  // nothing announced yet
  EXPECT_DOUBLE_EQ(device.info().limits.max_force, o.limits.max_force);
  device.start();
  Client client(device.port());
  client.send(hello(0));

  // The announced values, untouched by the simulator's own limits (the servo loop combines them).
  ASSERT_TRUE(eventually([&] { return device.poll_limits(limits); }));
  EXPECT_DOUBLE_EQ(limits.max_force, 3.5);
  EXPECT_DOUBLE_EQ(limits.max_stiffness, 0.01);
  EXPECT_DOUBLE_EQ(limits.max_torque, 0.0);
  EXPECT_DOUBLE_EQ(limits.position_resolution, 0.0);  // not announced
  EXPECT_EQ(limits.workspace.min(), Vec3(-80, -70, -60));
  EXPECT_EQ(limits.workspace.max(), Vec3(80, 70, 60));
  DeviceLimits again;
  EXPECT_FALSE(device.poll_limits(again));  // once per hello
  const DeviceInfo info = device.info();
  EXPECT_DOUBLE_EQ(info.limits.max_stiffness, 0.01);
  EXPECT_NE(info.description.find("test arm"), std::string::npos);
  device.stop();
}

TEST(UdpDevice, SendsTheWrenchAsGivenWithTheStatus) {
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  o.limits.max_force = 1.0;  // the bridge enforces nothing: the servo loop's Params do
  UdpDevice device(o);
  device.start();
  Client client(device.port());
  client.send(hello(0));
  client.send(pose(1));
  ASSERT_TRUE(eventually([&] { return device.read(now_s()).valid; }));

  // A wrench far above every limit goes out unchanged, with the status bytes and flags.
  DeviceStatus status;
  status.state = 2;  // inserting
  status.depth = 0.75;
  status.safety_flags = kSafetyClampedForce | kSafetyRamping;
  status.limits_acknowledged = true;
  device.set_status(status);
  device.write(Vec3(0, 0, 40.0), Vec3(600.0, 0, 0));
  bridge::WrenchPacket w;
  ASSERT_TRUE(client.receive(w));
  EXPECT_EQ(w.sequence, 1u);
  EXPECT_EQ(w.force, Vec3(0, 0, 40.0));
  EXPECT_EQ(w.torque, Vec3(600.0, 0, 0));
  EXPECT_EQ(w.state, 2);
  EXPECT_DOUBLE_EQ(w.depth, 0.75);
  EXPECT_EQ(w.flags, kSafetyClampedForce | kSafetyRamping | bridge::kWrenchLimitsAcknowledged);

  // Without the acknowledgement the flag is clear; a non-finite wrench, which the protocol forbids,
  // goes out as zero.
  status.limits_acknowledged = false;
  status.safety_flags = 0;
  device.set_status(status);
  device.write(Vec3(std::nan(""), 0, 0), Vec3::Zero());
  ASSERT_TRUE(client.receive(w));
  EXPECT_EQ(w.flags, 0);
  EXPECT_TRUE(w.force.isZero());
  device.stop();
}

}  // namespace
}  // namespace cariesim
