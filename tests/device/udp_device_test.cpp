// UdpDevice over loopback without a servo loop (the test thread plays the servo thread): a hello's
// limits come out of poll_limits once and as announced, and are withdrawn when another client starts
// a session without one; the wrench goes out as given (the bridge clamps nothing; the servo loop's
// Params bound it), and the status travels with it; but no more wrenches go out than the client sent
// packets, and none once it fell silent (ReplyBudget, also driven here with its own clock).
#include "cariesim/device/udp_device.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
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
  explicit Client(uint16_t port, long receive_timeout_us = 200000) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd_, reinterpret_cast<sockaddr*>(&to), sizeof(to)), 0);
    timeval wait{0, receive_timeout_us};  // per receive, so a missing answer fails instead of hanging
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

std::vector<uint8_t> pose(uint32_t sequence, double client_time = now_s()) {
  bridge::PosePacket p;
  p.sequence = sequence;
  p.client_time = client_time;
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
  LimitsAnnouncement news;
  EXPECT_FALSE(device.poll_limits(news));  // nothing announced yet
  EXPECT_DOUBLE_EQ(device.info().limits.max_force, o.limits.max_force);
  device.start();
  Client client(device.port());
  client.send(hello(0));

  // The announced values, untouched by the simulator's own limits (the servo loop combines them).
  ASSERT_TRUE(eventually([&] { return device.poll_limits(news); }));
  EXPECT_FALSE(news.withdrawn);
  const DeviceLimits& limits = news.limits;
  EXPECT_DOUBLE_EQ(limits.max_force, 3.5);
  EXPECT_DOUBLE_EQ(limits.max_stiffness, 0.01);
  EXPECT_DOUBLE_EQ(limits.max_torque, 0.0);
  EXPECT_DOUBLE_EQ(limits.position_resolution, 0.0);  // not announced
  EXPECT_EQ(limits.workspace.min(), Vec3(-80, -70, -60));
  EXPECT_EQ(limits.workspace.max(), Vec3(80, 70, 60));
  LimitsAnnouncement again;
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
  status.force_clamped = true;
  status.safety_flags = kSafetyRamping;
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
  EXPECT_EQ(w.flags,
            bridge::kWrenchForceClamped | bridge::kWrenchRamping | bridge::kWrenchLimitsAcknowledged);
  EXPECT_EQ(w.flags, 0x8005) << "the bits on the wire are the documented ones (docs/device-bridge.md)";

  // Without the acknowledgement the flag is clear; a non-finite wrench, which the protocol forbids,
  // goes out as zero. (It answers the next pose: each pose is answered once.)
  client.send(pose(2));
  ASSERT_TRUE(eventually([&] { return device.read(now_s()).sequence == 2; }));
  status.limits_acknowledged = false;
  status.force_clamped = false;
  status.safety_flags = 0;
  device.set_status(status);
  device.write(Vec3(std::nan(""), 0, 0), Vec3::Zero());
  ASSERT_TRUE(client.receive(w));
  EXPECT_EQ(w.flags, 0);
  EXPECT_TRUE(w.force.isZero());
  device.stop();
}

// The wrench flags are the protocol's own word (bridge::WrenchFlag): each fact of the cycle's status
// sets its documented bit, and nothing else does.
TEST(UdpDevice, EachStatusSetsItsWrenchFlag) {
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  UdpDevice device(o);
  device.start();
  Client client(device.port());
  struct Case {
    void (*set)(DeviceStatus&);
    uint16_t bit;
  };
  const Case cases[] = {
      {[](DeviceStatus& s) { s.force_clamped = true; }, 0x0001},
      {[](DeviceStatus& s) { s.torque_clamped = true; }, 0x0002},
      {[](DeviceStatus& s) { s.safety_flags = kSafetyRamping; }, 0x0004},
      {[](DeviceStatus& s) { s.safety_flags = kSafetyStale; }, 0x0008},
      {[](DeviceStatus& s) { s.safety_flags = kSafetyNonFinite; }, 0x0010},
      {[](DeviceStatus& s) { s.safety_flags = kSafetyInvalidInput; }, 0x0020},
      {[](DeviceStatus& s) { s.safety_flags = kSafetyJump; }, 0x0040},
      {[](DeviceStatus& s) { s.limits_acknowledged = true; }, 0x8000},
      {[](DeviceStatus& s) { s.step_flags = ~0u; }, 0x0000},  // the step's word is not sent
  };
  uint32_t sequence = 0;
  for (const Case& c : cases) {
    client.send(pose(++sequence));
    ASSERT_TRUE(eventually([&] { return device.read(now_s()).sequence == sequence; }));
    DeviceStatus status;
    c.set(status);
    device.set_status(status);
    device.write(Vec3::Zero(), Vec3::Zero());
    bridge::WrenchPacket w;
    ASSERT_TRUE(client.receive(w));
    EXPECT_EQ(w.flags, c.bit) << sequence;
  }
  device.stop();
}

TEST(UdpDevice, ANewClientWithoutAHelloWithdrawsTheEarlierHellosLimits) {
  // Client A announces 3.5 N and streams; it falls silent for the session timeout; client B streams
  // without a hello: A's limits are withdrawn (the servo loop goes back to the scene's) and info()
  // reports the options' limits again. A client that comes back after a silence keeps its own hello.
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  o.session_timeout = 0.2;
  o.limits.max_force = 9.0;
  UdpDevice device(o);
  device.start();
  LimitsAnnouncement news;
  uint32_t a_seq = 0;
  {
    Client a(device.port());
    a.send(hello(a_seq++));
    a.send(pose(a_seq++));
    ASSERT_TRUE(eventually([&] { return device.poll_limits(news); }));
    EXPECT_FALSE(news.withdrawn);
    EXPECT_DOUBLE_EQ(device.info().limits.max_force, 3.5);
    // A comes back after a silence (a new session of the same client): its hello still holds.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    a.send(pose(a_seq++));
    ASSERT_TRUE(eventually([&] { return device.bridge_counters().sessions == 2; }));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_FALSE(device.poll_limits(news));
    EXPECT_DOUBLE_EQ(device.info().limits.max_force, 3.5);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  Client b(device.port());
  b.send(pose(0));
  ASSERT_TRUE(eventually([&] { return device.poll_limits(news); }));
  EXPECT_TRUE(news.withdrawn);
  EXPECT_DOUBLE_EQ(device.info().limits.max_force, 9.0);
  EXPECT_EQ(device.info().description.find("test arm"), std::string::npos);
  // The pose that began B's session came after the withdrawal.
  EXPECT_TRUE(device.read(now_s()).valid);
  device.stop();
}

TEST(ReplyBudget, EachPacketAnsweredAtMostOnceAndNoneOnceSilent) {
  constexpr int64_t kMs = 1000000;
  constexpr int64_t t0 = 1000000 * kMs;  // any monotonic time
  ReplyBudget budget(1.0);
  // The servo loop's wrench echoes the newest pose it read: here the count of packets received.
  uint32_t newest = 0;
  EXPECT_FALSE(budget.take(t0, newest));  // nothing received yet

  // One packet: one reply, however often the servo loop writes.
  budget.received(t0);
  newest = 1;
  int replies = 0;
  for (int64_t t = t0; t < t0 + 3000 * kMs; t += kMs) replies += budget.take(t, newest);
  EXPECT_EQ(replies, 1);

  // A client at 100 Hz for 2 s, the servo loop at 1 kHz: a reply per packet.
  budget.reset();
  const int64_t t1 = t0 + 10000 * kMs;
  replies = 0;
  for (int64_t t = t1; t < t1 + 2000 * kMs; t += kMs) {
    if ((t - t1) % (10 * kMs) == 0) {
      budget.received(t);
      ++newest;
    }
    replies += budget.take(t, newest);
  }
  EXPECT_EQ(replies, 200);

  // A packet not answered within the window (the servo loop wrote nothing meanwhile) is not answered
  // later: the client has been silent for the session timeout.
  budget.reset();
  const int64_t t2 = t1 + 10000 * kMs;
  budget.received(t2);
  EXPECT_FALSE(budget.take(t2 + 1001 * kMs, ++newest));
  budget.received(t2 + 1100 * kMs);
  EXPECT_TRUE(budget.take(t2 + 1100 * kMs, ++newest));

  // A burst of 10000 packets, then 10 Hz for 5 s, then silence: every reply answers a packet of its
  // own received within the window before it, and every slow packet is answered.
  budget.reset();
  const int64_t t3 = t2 + 10000 * kMs;
  std::vector<int64_t> in;
  std::vector<std::size_t> answered;  // per reply: the packet it answers (the newest before it)
  for (int i = 0; i < 10000; ++i) {
    budget.received(t3);
    in.push_back(t3);
    ++newest;
  }
  for (int64_t t = t3; t < t3 + 8000 * kMs; t += kMs) {
    if (t > t3 && t <= t3 + 5000 * kMs && (t - t3) % (100 * kMs) == 0) {
      budget.received(t);
      in.push_back(t);
      ++newest;
    }
    if (budget.take(t, newest)) {
      answered.push_back(in.size() - 1);
      ASSERT_LE(t - in.back(), 1000 * kMs);
    }
  }
  EXPECT_EQ(answered.size(), 1u + 50u);
  for (std::size_t i = 1; i < answered.size(); ++i) EXPECT_GT(answered[i], answered[i - 1]);
}

// The test thread plays a servo loop at about 1 kHz for `seconds`, writing a wrench every cycle.
void serve(UdpDevice& device, double seconds) {
  const double start = now_s();
  while (now_s() - start < seconds) {
    (void)device.read(now_s());
    device.write(Vec3(0, 0, 1), Vec3::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

// Every wrench that arrived within `wait_s` after the last one.
std::vector<bridge::WrenchPacket> drain(int fd) {
  std::vector<bridge::WrenchPacket> out;
  uint8_t buffer[256];
  while (true) {
    const ssize_t n = ::recv(fd, buffer, sizeof(buffer), MSG_DONTWAIT);
    if (n < 0) return out;
    bridge::WrenchPacket w;
    if (bridge::parse_wrench(buffer, static_cast<std::size_t>(n), w) == bridge::ParseResult::Wrench)
      out.push_back(w);
  }
}

// A wrench for the pose before went out after the newest pose arrived: the newest is still
// answered (each wrench is charged to the pose it answers). Before, the earlier wrench used up the
// newest pose's credit and its answer was withheld, so a client's last pose could go unanswered.
TEST(ReplyBudget, TheNewestPoseIsAnsweredAfterAWrenchForTheOneBefore) {
  constexpr int64_t kMs = 1000000;
  constexpr int64_t t0 = 1000000 * kMs;
  ReplyBudget budget(1.0);
  budget.received(t0);        // pose 1
  budget.received(t0 + kMs);  // pose 2 arrives while the loop's wrench for pose 1 is on its way
  EXPECT_TRUE(budget.take(t0 + kMs, 1));
  EXPECT_TRUE(budget.take(t0 + 2 * kMs, 2));
  EXPECT_FALSE(budget.take(t0 + 3 * kMs, 2));  // each pose once
  EXPECT_FALSE(budget.take(t0 + 3 * kMs, 3));  // never more wrenches than packets
}

TEST(UdpDevice, OnePoseGetsOneWrenchNotAStream) {
  // One 80-byte pose, then silence, while the servo loop writes at ~1 kHz for 2 s: one wrench back
  // (the bridge once answered every cycle without end: 11,309 wrenches in 14 s).
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  UdpDevice device(o);
  device.start();
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(device.port());
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof(to)), 0);
  const std::vector<uint8_t> one = pose(7);
  ASSERT_EQ(::send(fd, one.data(), one.size(), 0), static_cast<ssize_t>(one.size()));
  ASSERT_TRUE(eventually([&] { return device.read(now_s()).valid; }));
  serve(device, 2.0);
  const std::vector<bridge::WrenchPacket> got = drain(fd);
  ::close(fd);
  const BridgeCounters c = device.bridge_counters();
  device.stop();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].sequence, 7u);
  EXPECT_EQ(c.sent, 1u);
  EXPECT_GT(c.withheld, 1000u);
}

TEST(UdpDevice, AClientSendingAt200HzGetsAWrenchPerPose) {
  // A client at 200 Hz for 1 s against a servo loop at ~1 kHz: a wrench for each pose (no more), each
  // echoing a pose it sent; after it stops, nothing more.
  UdpOptions o;
  o.port = 0;
  o.realtime_priority = 0;
  UdpDevice device(o);
  device.start();
  Client client(device.port(), 1000);
  std::atomic<bool> done{false};
  constexpr uint32_t kPoses = 200;
  std::thread sender([&] {
    for (uint32_t i = 1; i <= kPoses; ++i) {
      client.send(pose(i));
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    done.store(true);
  });
  const double start = now_s();
  while (!done.load() && now_s() - start < 30.0) serve(device, 0.01);
  sender.join();
  serve(device, 0.5);  // the last poses' wrenches, then silence
  std::vector<bridge::WrenchPacket> got;
  bridge::WrenchPacket w;
  while (client.receive(w)) got.push_back(w);
  const BridgeCounters c = device.bridge_counters();
  device.stop();
  EXPECT_EQ(c[BridgeVerdict::AcceptedPose], kPoses);
  EXPECT_LE(got.size(), kPoses);
  EXPECT_GE(got.size(), kPoses * 95 / 100);
  for (const bridge::WrenchPacket& x : got) {
    EXPECT_GE(x.sequence, 1u);
    EXPECT_LE(x.sequence, kPoses);
  }
  EXPECT_EQ(c.sent, got.size());
}

}  // namespace
}  // namespace cariesim
