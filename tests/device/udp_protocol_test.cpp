// The UDP bridge's wire protocol: the documented bytes (docs/device-bridge.md's worked example, made
// independently with Python's struct module), round trips, every rejection reason, and a seeded
// randomized-mutation fuzz test of the strict parser.
#include "cariesim/device/udp_protocol.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace cariesim {
namespace {

using namespace bridge;
using Bytes = std::vector<uint8_t>;

// docs/device-bridge.md, "Worked example": struct.pack('<IBBHIId3d4d', 0x4D495343, 1, 1, 0, 42, 1,
// 12.5, -22.5, 0.0, 8.25, 0.6, 0.0, 0.8, 0.0).
const Bytes kExamplePose = {
    0x43, 0x53, 0x49, 0x4d, 0x01, 0x01, 0x00, 0x00, 0x2a, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x29, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x36, 0xc0,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x20, 0x40,
    0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xe3, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xe9, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
// struct.pack('<IBBHIB3xdd3d3dd', 0x4D495343, 1, 0x81, 0x8001, 42, 1, 3.217, 12.5, 0, 0, 1.5, -2, 0,
// 0, 0).
const Bytes kExampleWrench = {0x43, 0x53, 0x49, 0x4d, 0x01, 0x81, 0x01, 0x80, 0x2a, 0x00, 0x00, 0x00, 0x01,
                              0x00, 0x00, 0x00, 0x23, 0xdb, 0xf9, 0x7e, 0x6a, 0xbc, 0x09, 0x40, 0x00, 0x00,
                              0x00, 0x00, 0x00, 0x00, 0x29, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                              0x00, 0x00, 0xf8, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x00,
                              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};

PosePacket example_pose() {
  PosePacket p;
  p.sequence = 42;
  p.buttons = 1;
  p.client_time = 12.5;
  p.pose.p = Vec3(-22.5, 0.0, 8.25);
  p.pose.q = Quat(0.6, 0.0, 0.8, 0.0);
  return p;
}

HelloPacket example_hello() {
  HelloPacket h;
  h.sequence = 7;
  h.client_time = 3.0;
  h.max_force = 8.5;
  h.max_stiffness = 3.0;
  h.max_torque = 515.0;
  h.workspace_min = Vec3(-80, -60, -40);
  h.workspace_max = Vec3(80, 60, 40);
  const char name[] = "Phantom Premium 3.0 6DOF";
  std::memcpy(h.name.data(), name, sizeof(name) - 1);
  return h;
}

Bytes encode(const PosePacket& p) {
  Bytes b(kMaxPacketSize);
  b.resize(encode_pose(p, b.data(), b.size()));
  return b;
}
Bytes encode(const HelloPacket& h) {
  Bytes b(kMaxPacketSize);
  b.resize(encode_hello(h, b.data(), b.size()));
  return b;
}

ParseResult parse(const Bytes& b) {
  ClientPacket out;
  return parse_client_packet(b.data(), b.size(), out);
}

void put_f64(Bytes& b, std::size_t at, double v) { std::memcpy(b.data() + at, &v, 8); }  // little-endian host

TEST(UdpProtocol, ExamplePoseHasTheDocumentedBytes) {
  EXPECT_EQ(encode(example_pose()), kExamplePose);
  ClientPacket out;
  ASSERT_EQ(parse_client_packet(kExamplePose.data(), kExamplePose.size(), out), ParseResult::Pose);
  EXPECT_EQ(out.type, PacketType::Pose);
  EXPECT_EQ(out.pose.sequence, 42u);
  EXPECT_EQ(out.pose.buttons, 1u);
  EXPECT_DOUBLE_EQ(out.pose.client_time, 12.5);
  EXPECT_EQ(out.pose.pose.p, Vec3(-22.5, 0.0, 8.25));
  EXPECT_NEAR(out.pose.pose.q.w(), 0.6, 1e-15);
  EXPECT_NEAR(out.pose.pose.q.y(), 0.8, 1e-15);
  EXPECT_FALSE(out.pose.has_velocity);
}

TEST(UdpProtocol, ExampleWrenchHasTheDocumentedBytes) {
  WrenchPacket w;
  w.sequence = 42;
  w.flags = 0x8001;
  w.state = 1;
  w.server_time = 3.217;
  w.client_time = 12.5;
  w.force = Vec3(0, 0, 1.5);
  w.torque = Vec3(-2, 0, 0);
  Bytes b(kWrenchSize);
  ASSERT_EQ(encode_wrench(w, b.data(), b.size()), kWrenchSize);
  EXPECT_EQ(b, kExampleWrench);
  WrenchPacket back;
  ASSERT_EQ(parse_wrench(b.data(), b.size(), back), ParseResult::Wrench);
  EXPECT_EQ(back.sequence, 42u);
  EXPECT_EQ(back.flags, 0x8001);
  EXPECT_EQ(back.state, 1);
  EXPECT_EQ(back.force, w.force);
  EXPECT_EQ(back.torque, w.torque);
  EXPECT_DOUBLE_EQ(back.server_time, 3.217);
  EXPECT_DOUBLE_EQ(back.client_time, 12.5);
}

TEST(UdpProtocol, PoseWithVelocityRoundTrips) {
  PosePacket p = example_pose();
  p.has_velocity = true;
  p.velocity = Vec3(1.5, -2.0, 30.0);
  p.angular_velocity = Vec3(0.1, 0.2, -0.3);
  p.sequence = 0xfffffffeu;
  p.buttons = 0x80000003u;
  const Bytes b = encode(p);
  ASSERT_EQ(b.size(), kPoseWithVelocitySize);
  EXPECT_EQ(b[6], 1);  // the velocity flag
  ClientPacket out;
  ASSERT_EQ(parse_client_packet(b.data(), b.size(), out), ParseResult::Pose);
  EXPECT_EQ(out.pose.sequence, p.sequence);
  EXPECT_EQ(out.pose.buttons, p.buttons);
  EXPECT_TRUE(out.pose.has_velocity);
  EXPECT_EQ(out.pose.velocity, p.velocity);
  EXPECT_EQ(out.pose.angular_velocity, p.angular_velocity);
}

TEST(UdpProtocol, HelloRoundTrips) {
  const HelloPacket h = example_hello();
  const Bytes b = encode(h);
  ASSERT_EQ(b.size(), kHelloSize);
  ClientPacket out;
  ASSERT_EQ(parse_client_packet(b.data(), b.size(), out), ParseResult::Hello);
  EXPECT_EQ(out.type, PacketType::Hello);
  EXPECT_EQ(out.hello.sequence, 7u);
  EXPECT_DOUBLE_EQ(out.hello.max_force, 8.5);
  EXPECT_DOUBLE_EQ(out.hello.max_stiffness, 3.0);
  EXPECT_DOUBLE_EQ(out.hello.max_torque, 515.0);
  EXPECT_EQ(out.hello.workspace_min, h.workspace_min);
  EXPECT_EQ(out.hello.workspace_max, h.workspace_max);
  EXPECT_EQ(out.hello.name_view(), "Phantom Premium 3.0 6DOF");
}

TEST(UdpProtocol, EncodersRefuseSmallBuffers) {
  std::array<uint8_t, 64> small{};
  EXPECT_EQ(encode_pose(example_pose(), small.data(), small.size()), 0u);
  EXPECT_EQ(encode_hello(example_hello(), small.data(), small.size()), 0u);
  EXPECT_EQ(encode_wrench(WrenchPacket{}, small.data(), small.size()), 0u);
}

TEST(UdpProtocol, EachRejectionReason) {
  const Bytes pose = encode(example_pose());
  const Bytes hello = encode(example_hello());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* what;
    Bytes bytes;
    ParseResult expected;
  };
  std::vector<Case> cases;
  auto with = [](Bytes b, auto&& change) {
    change(b);
    return b;
  };
  // Truncated.
  cases.push_back({"empty", {}, ParseResult::Truncated});
  cases.push_back({"3 bytes", Bytes(pose.begin(), pose.begin() + 3), ParseResult::Truncated});
  cases.push_back({"header only", Bytes(pose.begin(), pose.begin() + 11), ParseResult::Truncated});
  cases.push_back({"pose minus one", Bytes(pose.begin(), pose.end() - 1), ParseResult::Truncated});
  cases.push_back(
      {"velocity flag without velocity", with(pose, [](Bytes& b) { b[6] = 1; }), ParseResult::Truncated});
  cases.push_back({"hello minus one", Bytes(hello.begin(), hello.end() - 1), ParseResult::Truncated});
  // Magic and version.
  cases.push_back({"bad magic", with(pose, [](Bytes& b) { b[0] = 'X'; }), ParseResult::BadMagic});
  cases.push_back({"bad magic, short", {'X', 'S', 'I', 'M', 1}, ParseResult::BadMagic});
  cases.push_back({"version 2", with(pose, [](Bytes& b) { b[4] = 2; }), ParseResult::BadVersion});
  cases.push_back({"version 0", with(pose, [](Bytes& b) { b[4] = 0; }), ParseResult::BadVersion});
  // Malformed.
  cases.push_back({"pose plus one", with(pose, [](Bytes& b) { b.push_back(0); }), ParseResult::Malformed});
  cases.push_back({"unknown type", with(pose, [](Bytes& b) { b[5] = 9; }), ParseResult::Malformed});
  cases.push_back(
      {"a wrench from a client", with(pose, [](Bytes& b) { b[5] = 0x81; }), ParseResult::Malformed});
  cases.push_back({"unknown pose flag", with(pose, [](Bytes& b) { b[7] = 0x80; }), ParseResult::Malformed});
  cases.push_back({"hello with flags", with(hello, [](Bytes& b) { b[6] = 1; }), ParseResult::Malformed});
  cases.push_back({"hello reserved bytes", with(hello, [](Bytes& b) { b[13] = 1; }), ParseResult::Malformed});
  cases.push_back(
      {"hello zero force", with(hello, [](Bytes& b) { put_f64(b, 24, 0.0); }), ParseResult::Malformed});
  cases.push_back(
      {"hello negative torque", with(hello, [](Bytes& b) { put_f64(b, 40, -1.0); }), ParseResult::Malformed});
  cases.push_back({"hello inverted workspace", with(hello, [](Bytes& b) { put_f64(b, 48, 500.0); }),
                   ParseResult::Malformed});
  cases.push_back(
      {"hello control char in name", with(hello, [](Bytes& b) { b[97] = '\n'; }), ParseResult::Malformed});
  cases.push_back(
      {"hello text after the padding", with(hello, [](Bytes& b) { b[127] = 'x'; }), ParseResult::Malformed});
  // Non-finite.
  cases.push_back(
      {"NaN position", with(pose, [&](Bytes& b) { put_f64(b, 32, nan); }), ParseResult::NonFinite});
  cases.push_back(
      {"infinite time", with(pose, [&](Bytes& b) { put_f64(b, 16, inf); }), ParseResult::NonFinite});
  cases.push_back(
      {"NaN quaternion", with(pose, [&](Bytes& b) { put_f64(b, 56, nan); }), ParseResult::NonFinite});
  cases.push_back(
      {"hello NaN stiffness", with(hello, [&](Bytes& b) { put_f64(b, 32, nan); }), ParseResult::NonFinite});
  // Non-unit quaternions.
  cases.push_back({"zero quaternion", with(pose, [](Bytes& b) { put_f64(b, 48, 0.0), put_f64(b, 64, 0.0); }),
                   ParseResult::NonUnit});
  cases.push_back({"quaternion of length 2",
                   with(pose, [](Bytes& b) { put_f64(b, 48, 1.2), put_f64(b, 64, 1.6); }),
                   ParseResult::NonUnit});
  cases.push_back({"quaternion of length 1.01",
                   with(pose, [](Bytes& b) { put_f64(b, 48, 0.606), put_f64(b, 64, 0.808); }),
                   ParseResult::NonUnit});

  for (const Case& c : cases)
    EXPECT_EQ(parse(c.bytes), c.expected) << c.what << ": got " << parse_result_name(parse(c.bytes));
  // A slightly off quaternion (within the tolerance) is accepted and normalised.
  ClientPacket out;
  const Bytes near_unit = with(pose, [](Bytes& b) { put_f64(b, 48, 0.6003); });
  ASSERT_EQ(parse_client_packet(near_unit.data(), near_unit.size(), out), ParseResult::Pose);
  EXPECT_NEAR(out.pose.pose.q.norm(), 1.0, 1e-12);
}

TEST(UdpProtocol, WrenchRejections) {
  WrenchPacket w;
  w.force = Vec3(1, 2, 3);
  Bytes b(kWrenchSize);
  encode_wrench(w, b.data(), b.size());
  WrenchPacket out;
  EXPECT_EQ(parse_wrench(b.data(), b.size() - 1, out), ParseResult::Truncated);
  Bytes longer = b;
  longer.push_back(0);
  EXPECT_EQ(parse_wrench(longer.data(), longer.size(), out), ParseResult::Malformed);
  Bytes bad_state = b;
  bad_state[12] = 4;
  EXPECT_EQ(parse_wrench(bad_state.data(), bad_state.size(), out), ParseResult::Malformed);
  Bytes reserved_flag = b;
  reserved_flag[7] = 0x01;  // bit 8
  EXPECT_EQ(parse_wrench(reserved_flag.data(), reserved_flag.size(), out), ParseResult::Malformed);
  Bytes nan_force = b;
  put_f64(nan_force, 40, std::nan(""));
  EXPECT_EQ(parse_wrench(nan_force.data(), nan_force.size(), out), ParseResult::NonFinite);
  const Bytes pose = encode(example_pose());
  EXPECT_EQ(parse_wrench(pose.data(), pose.size(), out), ParseResult::Malformed);  // not a wrench
  EXPECT_EQ(parse_wrench(nullptr, 0, out), ParseResult::Truncated);
}

// What the fuzz test demands of every accepted packet: finite values, a unit quaternion, and the
// same packet again after encoding it and parsing the result (the format has one meaning per byte).
void check_accepted(const ClientPacket& p, ParseResult r) {
  ClientPacket again;
  if (r == ParseResult::Pose) {
    ASSERT_TRUE(p.pose.pose.p.allFinite() && std::isfinite(p.pose.client_time));
    ASSERT_NEAR(p.pose.pose.q.norm(), 1.0, 1e-12);
    const Bytes b = encode(p.pose);
    ASSERT_EQ(parse_client_packet(b.data(), b.size(), again), ParseResult::Pose);
    ASSERT_EQ(again.pose.sequence, p.pose.sequence);
    ASSERT_EQ(again.pose.buttons, p.pose.buttons);
    ASSERT_EQ(again.pose.pose.p, p.pose.pose.p);
    ASSERT_TRUE(again.pose.pose.q.coeffs().isApprox(p.pose.pose.q.coeffs(), 1e-15));
    ASSERT_EQ(again.pose.velocity, p.pose.velocity);
  } else {
    ASSERT_EQ(r, ParseResult::Hello);
    ASSERT_GT(p.hello.max_force, 0.0);
    ASSERT_GT(p.hello.max_stiffness, 0.0);
    ASSERT_GE(p.hello.max_torque, 0.0);
    for (char c : p.hello.name_view()) ASSERT_TRUE(c >= 0x20 && c <= 0x7e);
    const Bytes b = encode(p.hello);
    ASSERT_EQ(parse_client_packet(b.data(), b.size(), again), ParseResult::Hello);
    ASSERT_EQ(again.hello.name_view(), p.hello.name_view());
    ASSERT_EQ(again.hello.max_force, p.hello.max_force);
  }
}

TEST(UdpProtocol, FuzzRandomMutationsOfValidPackets) {
  // Seeded, bounded (iterations and ~2 s): mutate valid packets (bit flips, random bytes, special
  // doubles, truncation, extension, splices) and parse them. The parser must never read out of
  // bounds (ASan builds check), must answer a known result, and every accepted packet must pass
  // check_accepted. Each result is counted to show the mutations reach every branch.
  std::mt19937_64 rng(0xC0FFEE);
  PosePacket with_velocity = example_pose();
  with_velocity.has_velocity = true;
  with_velocity.velocity = Vec3(1, 2, 3);
  const std::vector<Bytes> seeds = {encode(example_pose()), encode(with_velocity), encode(example_hello())};
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(),
                             std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(),
                             0.0,
                             -0.0,
                             1.0,
                             -1.0,
                             1e308,
                             std::numeric_limits<double>::denorm_min()};
  std::array<int, 9> seen{};
  const auto stop_at = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  int iterations = 0;
  for (; iterations < 400000 && std::chrono::steady_clock::now() < stop_at; ++iterations) {
    Bytes b = seeds[rng() % seeds.size()];
    const int mutations = 1 + static_cast<int>(rng() % 4);
    for (int m = 0; m < mutations; ++m) {
      switch (rng() % 7) {
        case 0:  // flip a bit
          if (!b.empty()) b[rng() % b.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
          break;
        case 1:  // a random byte
          if (!b.empty()) b[rng() % b.size()] = static_cast<uint8_t>(rng());
          break;
        case 2:  // a special double at an 8-byte field
          if (b.size() >= 24)
            put_f64(b, 16 + 8 * (rng() % ((b.size() - 16) / 8)), specials[rng() % std::size(specials)]);
          break;
        case 3:  // truncate
          b.resize(rng() % (b.size() + 1));
          break;
        case 4:  // extend
          b.resize(b.size() + 1 + rng() % 16, static_cast<uint8_t>(rng()));
          break;
        case 5:  // splice the start of another seed
        {
          const Bytes& other = seeds[rng() % seeds.size()];
          const std::size_t n = std::min(b.size(), other.size()) * (rng() % 100) / 100;
          std::copy(other.begin(), other.begin() + static_cast<std::ptrdiff_t>(n), b.begin());
          break;
        }
        default:  // a random small quaternion perturbation (near the unit tolerance)
          if (b.size() >= 56) put_f64(b, 48, 0.6 + (static_cast<double>(rng() % 2001) - 1000.0) * 2e-6);
          break;
      }
    }
    ClientPacket out;
    const ParseResult r = parse_client_packet(b.data(), b.size(), out);
    ASSERT_LE(static_cast<int>(r), static_cast<int>(ParseResult::NonUnit));
    ++seen[static_cast<std::size_t>(r)];
    if (r == ParseResult::Pose || r == ParseResult::Hello) {
      check_accepted(out, r);
      if (HasFatalFailure()) return;
    }
  }
  EXPECT_GT(iterations, 1000);
  for (ParseResult r :
       {ParseResult::Pose, ParseResult::Hello, ParseResult::Truncated, ParseResult::Malformed,
        ParseResult::BadMagic, ParseResult::BadVersion, ParseResult::NonFinite, ParseResult::NonUnit})
    EXPECT_GT(seen[static_cast<std::size_t>(r)], 0) << parse_result_name(r);
  EXPECT_EQ(seen[static_cast<std::size_t>(ParseResult::Wrench)], 0);
}

TEST(UdpProtocol, FuzzRandomBytes) {
  // Pure noise of every length up to twice the largest packet: never accepted unless it starts with
  // the magic and version (vanishingly rare), never a crash.
  std::mt19937_64 rng(12345);
  int accepted = 0;
  for (int i = 0; i < 100000; ++i) {
    Bytes b(rng() % (2 * kMaxPacketSize + 1));
    for (uint8_t& x : b) x = static_cast<uint8_t>(rng());
    const ParseResult r = parse(b);
    accepted += r == ParseResult::Pose || r == ParseResult::Hello;
  }
  EXPECT_EQ(accepted, 0);
}

}  // namespace
}  // namespace cariesim
