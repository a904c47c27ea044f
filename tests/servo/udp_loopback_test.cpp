// The UDP bridge end to end over loopback: a client socket streams poses to a UdpDevice driven by a
// real ServoLoop on friction-block; wrenches come back echoing the sequence numbers; malformed,
// truncated, out-of-order, duplicate, stale, non-finite, non-unit and foreign packets are rejected and
// counted while the loop runs on; silence zeroes the force and stops the wrenches (each pose is
// answered once at most); a hello's limits bound the wrench and set the coupling stiffness through the
// servo loop's Params, and a new client without a hello or a refused hello puts the scene's back. No
// wall-clock timing is asserted.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstring>
#include <map>
#include <thread>
#include <vector>

#include "cariesim/device/safety.hpp"
#include "cariesim/device/udp_device.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using Bytes = std::vector<uint8_t>;

double client_clock() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

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
  }
  ~Client() { ::close(fd_); }
  void send(const uint8_t* data, std::size_t size) const {
    EXPECT_EQ(::send(fd_, data, size, 0), static_cast<ssize_t>(size));
  }
  void send(const Bytes& b) const { send(b.data(), b.size()); }
  // Every wrench that arrived, in order (non-blocking).
  void drain(std::vector<bridge::WrenchPacket>& out, int& invalid) const {
    uint8_t buffer[256];
    while (true) {
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), MSG_DONTWAIT);
      if (n < 0) return;
      bridge::WrenchPacket w;
      if (bridge::parse_wrench(buffer, static_cast<std::size_t>(n), w) == bridge::ParseResult::Wrench)
        out.push_back(w);
      else
        ++invalid;
    }
  }

 private:
  int fd_ = -1;
};

Bytes pose_packet(uint32_t sequence, double client_time, const Pose& pose) {
  bridge::PosePacket p;
  p.sequence = sequence;
  p.client_time = client_time;
  p.pose = pose;
  Bytes b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_pose(p, b.data(), b.size()));
  return b;
}

Bytes hello_packet(uint32_t sequence, double max_force, double max_stiffness = 1.0) {
  bridge::HelloPacket h;
  h.sequence = sequence;
  h.client_time = client_clock();
  h.max_force = max_force;
  h.max_stiffness = max_stiffness;
  h.max_torque = 300.0;
  h.workspace_min = Vec3::Constant(-100);
  h.workspace_max = Vec3::Constant(100);
  std::memcpy(h.name.data(), "loopback test", 13);
  Bytes b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_hello(h, b.data(), b.size()));
  return b;
}

struct Bridge {
  explicit Bridge(Model& model) : device(options(model)), loop(model, device, servo_options()) {}
  static UdpOptions options(const Model& m) {
    UdpOptions o;
    o.port = 0;
    o.home = m.tool_home;
    o.limits = m.defaults.limits;
    // A transit timeout far above any scheduling stall of a loaded test machine, so only the packet
    // sent as stale on purpose (2 s old) is judged stale.
    o.timeout = 0.5;
    return o;
  }
  static ServoOptions servo_options() {
    ServoOptions o;
    o.realtime = false;
    o.safety.ramp_time = 0.05;
    return o;
  }
  UdpDevice device;
  ServoLoop loop;
};

TEST(UdpLoopback, PosesInWrenchesOutRejectionsCountedWhileTheLoopRuns) {
  Model model = test::friction_block();
  Bridge bridge(model);
  bridge.loop.start();  // starts the device too
  ASSERT_GT(bridge.device.port(), 0);
  Client client(bridge.device.port());
  const Trajectory path = test::press_and_slide(model, 1.0, 1.0);
  TrajectoryCursor cursor(path);
  std::map<uint32_t, double> sent_time;  // sequence -> client time
  std::vector<bridge::WrenchPacket> wrenches;
  int invalid = 0;
  uint32_t seq = 0;

  // The device announces 5 N; then it streams poses down onto the block and along it, ~1 kHz.
  client.send(hello_packet(seq++, 5.0));
  auto stream = [&](int count, double from) {
    for (int i = 0; i < count; ++i) {
      const double t = client_clock();
      sent_time[seq] = t;
      client.send(pose_packet(seq++, t, cursor.at(from + 0.001 * i)));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      client.drain(wrenches, invalid);
    }
  };
  stream(600, 0.0);
  ASSERT_TRUE(
      test::wait_for([&] { return bridge.device.bridge_counters()[BridgeVerdict::AcceptedPose] == 600; }));
  ASSERT_TRUE(test::wait_for([&] {
    client.drain(wrenches, invalid);
    return !wrenches.empty() && wrenches.back().sequence == seq - 1;
  }));

  // Wrenches echo sent sequence numbers (and their client times), in order, within the announced
  // 5 N (the servo loop's Params took the hello's limits; the bridge sends what it is given); the
  // tool pressed on the block.
  EXPECT_EQ(invalid, 0);
  uint32_t previous = 0;
  int pressing = 0, acknowledged = 0;
  for (const bridge::WrenchPacket& w : wrenches) {
    ASSERT_TRUE(sent_time.count(w.sequence)) << w.sequence;
    EXPECT_DOUBLE_EQ(w.client_time, sent_time[w.sequence]);
    EXPECT_GE(w.sequence, previous);
    previous = w.sequence;
    EXPECT_LE(w.force.norm(), 5.0 + 1e-9);
    pressing += w.state == static_cast<uint8_t>(InteractionState::Sliding) && w.force.norm() > 0.1;
    acknowledged += (w.flags & bridge::kWrenchLimitsAcknowledged) != 0;
  }
  EXPECT_GT(pressing, 0);
  EXPECT_EQ(acknowledged, static_cast<int>(wrenches.size()));
  EXPECT_NE(bridge.device.info().description.find("loopback test"), std::string::npos);
  EXPECT_DOUBLE_EQ(bridge.device.info().limits.max_force, 5.0);
  PublishedParams published;
  ASSERT_TRUE(test::wait_for([&] {
    bridge.loop.latest_params(published);
    return published.params.limits.max_force == 5.0;
  }));

  // Bad packets, while the loop runs.
  const uint64_t cycles_before = bridge.loop.timing().cycles;
  const Pose here = cursor.at(0.6);
  const Bytes good = pose_packet(seq, client_clock(), here);
  Bytes longer = good;
  longer.push_back(0);
  Bytes unknown_type = good;
  unknown_type[5] = 7;
  Bytes magic = good;
  magic[0] = 'X';
  Bytes version = good;
  version[4] = 3;
  Pose nan_pose = here;
  nan_pose.p.y() = std::nan("");
  Pose long_quat = here;
  long_quat.q.coeffs() *= 1.5;
  client.send(longer);                                        // malformed
  client.send(unknown_type);                                  // malformed
  client.send(good.data(), 40);                               // truncated
  client.send(good.data(), 8);                                // truncated
  client.send(magic);                                         // bad magic
  client.send(version);                                       // bad version
  client.send(pose_packet(seq, client_clock(), nan_pose));    // non-finite
  client.send(pose_packet(seq, client_clock(), long_quat));   // non-unit
  client.send(pose_packet(seq - 1, client_clock(), here));    // duplicate of the last accepted
  client.send(pose_packet(seq - 5, client_clock(), here));    // out of order
  client.send(pose_packet(seq - 300, client_clock(), here));  // out of order
  client.send(pose_packet(seq, client_clock() - 2.0, here));  // stale: 2 s in transit
  {
    Client intruder(bridge.device.port());
    intruder.send(pose_packet(seq, client_clock(), here));  // foreign
  }
  const uint64_t expected_rejections = 13;
  ASSERT_TRUE(
      test::wait_for([&] { return bridge.device.bridge_counters().rejected() == expected_rejections; }));
  const BridgeCounters c = bridge.device.bridge_counters();
  EXPECT_EQ(c[BridgeVerdict::Malformed], 2u);
  EXPECT_EQ(c[BridgeVerdict::Truncated], 2u);
  EXPECT_EQ(c[BridgeVerdict::BadMagic], 1u);
  EXPECT_EQ(c[BridgeVerdict::BadVersion], 1u);
  EXPECT_EQ(c[BridgeVerdict::NonFinite], 1u);
  EXPECT_EQ(c[BridgeVerdict::NonUnit], 1u);
  EXPECT_EQ(c[BridgeVerdict::Duplicate], 1u);
  EXPECT_EQ(c[BridgeVerdict::OutOfOrder], 2u);
  EXPECT_EQ(c[BridgeVerdict::Stale], 1u);
  EXPECT_EQ(c[BridgeVerdict::Foreign], 1u);
  EXPECT_EQ(c[BridgeVerdict::AcceptedPose], 600u);
  EXPECT_EQ(c[BridgeVerdict::AcceptedHello], 1u);

  // The loop ran on, and valid poses are still accepted and answered.
  stream(100, 0.6);
  ASSERT_TRUE(
      test::wait_for([&] { return bridge.device.bridge_counters()[BridgeVerdict::AcceptedPose] == 700; }));
  ASSERT_TRUE(test::wait_for([&] {
    client.drain(wrenches, invalid);
    return wrenches.back().sequence == seq - 1;
  }));
  EXPECT_GT(bridge.loop.timing().cycles, cycles_before);
  EXPECT_TRUE(bridge.loop.running());

  // Silence: the loop runs on with zero force flagged stale, and the bridge stops answering: never
  // more wrenches than the client sent packets.
  ServoSnapshot snapshot;
  ASSERT_TRUE(test::wait_for(
      [&] { return bridge.loop.latest(snapshot) && (snapshot.safety_flags & kSafetyStale) != 0; }));
  EXPECT_TRUE(snapshot.force.isZero());
  EXPECT_TRUE(snapshot.torque.isZero());
  ASSERT_TRUE(test::wait_for([&] { return bridge.device.bridge_counters().withheld > 100; }));
  const BridgeCounters silent = bridge.device.bridge_counters();
  ASSERT_TRUE(
      test::wait_for([&] { return bridge.device.bridge_counters().withheld > silent.withheld + 100; }));
  EXPECT_EQ(bridge.device.bridge_counters().sent, silent.sent);
  EXPECT_LE(silent.sent, silent[BridgeVerdict::AcceptedPose] + silent[BridgeVerdict::AcceptedHello]);
  client.drain(wrenches, invalid);
  EXPECT_EQ(wrenches.size(), silent.sent);
  bridge.loop.stop();

  // The counters as the viewer's panel sees them.
  const std::vector<DeviceCounter> named = bridge.device.counters();
  bool found_stale = false;
  for (const DeviceCounter& n : named)
    if (std::string(n.name) == "rejected_stale") found_stale = n.value == 1;
  EXPECT_TRUE(found_stale);
  EXPECT_GT(bridge.device.bridge_counters().sent, 0u);
  EXPECT_EQ(bridge.device.bridge_counters().send_errors, 0u);
}

// Force per mm of haptic-graphic offset (N/mm) over the cycles of `samples` that slid with the force
// fully ramped in and a fresh pose; 0 when none did.
double felt_stiffness(const std::vector<ServoSnapshot>& samples, int& counted) {
  double sum = 0.0;
  counted = 0;
  for (const ServoSnapshot& s : samples) {
    const double offset = (s.out.graphic.p - s.out.haptic.p).norm();
    if (s.out.state != InteractionState::Sliding || s.safety_flags != 0 || offset < 0.1) continue;
    sum += s.force.norm() / offset;
    ++counted;
  }
  return counted > 0 ? sum / counted : 0.0;
}

TEST(UdpLoopback, AnnouncedStiffnessSetsTheCouplingAndIsReported) {
  // A client announcing 1 N/mm presses 1 mm into the block and slides; then it announces 0.01 N/mm
  // (a new session) and slides on. The wrench for a given haptic-graphic offset is 100x smaller:
  // the coupling (and eq. 6's k_p) is the device's maximum stiffness, within the scene's.
  Model model = test::friction_block();
  Bridge bridge(model);
  bridge.loop.start();
  Client client(bridge.device.port());
  const Trajectory path = test::press_and_slide(model, 1.0, 2.0);
  TrajectoryCursor cursor(path);
  std::vector<bridge::WrenchPacket> wrenches;
  int invalid = 0;
  uint32_t seq = 0;
  // Streams poses of path times [from, to) at ~1 kHz and keeps the snapshots after `measure_from`.
  const auto stream = [&](double from, double to, double measure_from, std::vector<ServoSnapshot>& out) {
    ServoSnapshot s;
    for (double t = from; t < to; t += 0.001) {
      client.send(pose_packet(seq++, client_clock(), cursor.at(t)));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      if (bridge.loop.latest(s) && t >= measure_from) out.push_back(s);
      client.drain(wrenches, invalid);
    }
  };
  PublishedParams published;
  const auto wait_stiffness = [&](double k) {
    return test::wait_for([&] {
      bridge.loop.latest_params(published);
      return published.params.limits.max_stiffness == k;
    });
  };

  // 1 N/mm: pressed and sliding from path time 0.4 s on.
  client.send(hello_packet(seq++, 22.0, 1.0));
  ASSERT_TRUE(wait_stiffness(1.0));
  std::vector<ServoSnapshot> stiff, soft;
  stream(0.0, 0.9, 0.4, stiff);
  // 0.01 N/mm: the servo thread tightens its Params; measured once they are in force.
  client.send(hello_packet(seq++, 22.0, 0.01));
  ASSERT_TRUE(wait_stiffness(0.01));
  EXPECT_DOUBLE_EQ(published.params.gains.k_trans, 0.01);
  stream(0.9, 1.8, 1.0, soft);
  bridge.loop.stop();

  int n_stiff = 0, n_soft = 0;
  const double k_stiff = felt_stiffness(stiff, n_stiff);
  const double k_soft = felt_stiffness(soft, n_soft);
  ASSERT_GT(n_stiff, 20);
  ASSERT_GT(n_soft, 20);
  EXPECT_NEAR(k_stiff, 1.0, 1e-6);
  EXPECT_NEAR(k_soft, 0.01, 1e-8);
  EXPECT_NEAR(k_stiff / k_soft, 100.0, 1e-3);

  // The limits are reported: by the device (as announced), in the published Params, to the client.
  EXPECT_DOUBLE_EQ(bridge.device.info().limits.max_stiffness, 0.01);
  EXPECT_DOUBLE_EQ(published.params.limits.max_stiffness, 0.01);
  ASSERT_FALSE(wrenches.empty());
  EXPECT_NE(wrenches.back().flags & bridge::kWrenchLimitsAcknowledged, 0);
  EXPECT_EQ(invalid, 0);
}

TEST(UdpLoopback, EachSessionStartsFromTheScenesLimits) {
  // Client A announces 0.1 N and streams: its wrenches are acknowledged. It falls silent; client B
  // streams without a hello: the scene's limits apply, unacknowledged (B once inherited A's 0.1 N).
  // B's hello announcing 1e-300 N is refused, naming why: still the scene's, unacknowledged.
  Model model = test::friction_block();
  UdpOptions options = Bridge::options(model);
  options.session_timeout = 0.3;
  UdpDevice device(options);
  ServoLoop loop(model, device, Bridge::servo_options());
  loop.start();
  const Pose home = model.tool_home;
  PublishedParams published;
  const auto max_force_is = [&](double f) {
    return test::wait_for([&] {
      loop.latest_params(published);
      return published.params.limits.max_force == f;
    });
  };
  // Streams `count` poses at ~1 kHz and returns the last wrench that came back.
  const auto stream = [&](const Client& client, uint32_t& seq, int count) {
    std::vector<bridge::WrenchPacket> wrenches;
    int invalid = 0;
    for (int i = 0; i < count; ++i) {
      client.send(pose_packet(seq++, client_clock(), home));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_TRUE(test::wait_for([&] {
      client.drain(wrenches, invalid);
      return !wrenches.empty() && wrenches.back().sequence == seq - 1;
    }));
    EXPECT_EQ(invalid, 0);
    return wrenches.empty() ? bridge::WrenchPacket{} : wrenches.back();
  };
  const double scene_force = model.defaults.limits.max_force;
  {
    Client a(device.port());
    uint32_t seq = 0;
    a.send(hello_packet(seq++, 0.1));
    ASSERT_TRUE(max_force_is(0.1));
    EXPECT_NE(stream(a, seq, 50).flags & bridge::kWrenchLimitsAcknowledged, 0);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  Client b(device.port());
  uint32_t seq = 1000;
  const bridge::WrenchPacket b_last = stream(b, seq, 50);
  ASSERT_TRUE(max_force_is(scene_force));
  EXPECT_EQ(b_last.flags & bridge::kWrenchLimitsAcknowledged, 0);
  EXPECT_EQ(published.params.gains.k_trans, model.defaults.gains.k_trans);
  EXPECT_DOUBLE_EQ(device.info().limits.max_force, scene_force);

  b.send(hello_packet(seq++, 1e-300));
  ASSERT_TRUE(test::wait_for([&] { return loop.refused_limits() == 1; }));
  EXPECT_EQ(stream(b, seq, 50).flags & bridge::kWrenchLimitsAcknowledged, 0);
  loop.latest_params(published);
  EXPECT_EQ(published.params.limits.max_force, scene_force);
  loop.stop();
  ParamProblem why;
  ASSERT_TRUE(loop.latest_refusal(why));
  EXPECT_STREQ(why.field, "max_force");
}

TEST(UdpLoopback, StreamingAllocatesNothing) {
  // With the servo, receiver and sender threads running and a client streaming, the whole process
  // allocates nothing (each packet is encoded at send time, with its client time, into a buffer on
  // the stack).
  Model model = test::friction_block();
  Bridge bridge(model);
  bridge.loop.start();
  Client client(bridge.device.port());
  constexpr uint32_t kPackets = 400;
  std::array<uint8_t, bridge::kMaxPacketSize> buffer{};
  auto send_pose = [&](uint32_t i) {
    bridge::PosePacket p;
    p.sequence = i;
    p.client_time = client_clock();
    p.pose = test::home_at(model, model.tool_home.p + Vec3(0.01 * i, 0, 0));
    client.send(buffer.data(), bridge::encode_pose(p, buffer.data(), buffer.size()));
  };
  std::vector<bridge::WrenchPacket> wrenches;
  wrenches.reserve(100000);
  int invalid = 0;
  for (uint32_t i = 0; i < 100; ++i) send_pose(i);
  ASSERT_TRUE(test::wait_for([&] {
    client.drain(wrenches, invalid);
    return !wrenches.empty();
  }));

  const std::size_t before = test::allocation_count();
  for (uint32_t i = 100; i < kPackets; ++i) {
    send_pose(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    client.drain(wrenches, invalid);
  }
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (bridge.device.bridge_counters()[BridgeVerdict::AcceptedPose] < kPackets &&
         std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const std::size_t after = test::allocation_count();
  bridge.loop.stop();
  EXPECT_EQ(after - before, 0u);
  EXPECT_EQ(bridge.device.bridge_counters()[BridgeVerdict::AcceptedPose], kPackets);
  EXPECT_GT(wrenches.size(), 1u);
  EXPECT_EQ(invalid, 0);
}

}  // namespace
}  // namespace cariesim
