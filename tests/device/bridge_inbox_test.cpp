// BridgeInbox: the UDP bridge's acceptance rules without sockets: sequence order, duplicates,
// staleness with an unknown clock offset, foreign clients, sessions, and that each rejection reason
// is counted.
#include <gtest/gtest.h>

#include <vector>

#include "cariesim/device/udp_device.hpp"

namespace cariesim {
namespace {

using Bytes = std::vector<uint8_t>;
constexpr uint64_t kClient = 0x7f00000112345ull;
constexpr uint64_t kOther = 0x7f00000254321ull;

Bytes pose(uint32_t sequence, double client_time, const Vec3& p = Vec3(1, 2, 3)) {
  bridge::PosePacket packet;
  packet.sequence = sequence;
  packet.client_time = client_time;
  packet.pose.p = p;
  Bytes b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_pose(packet, b.data(), b.size()));
  return b;
}

Bytes hello(uint32_t sequence, double client_time) {
  bridge::HelloPacket h;
  h.sequence = sequence;
  h.client_time = client_time;
  h.max_force = 5.0;
  h.max_stiffness = 1.0;
  h.max_torque = 100.0;
  Bytes b(bridge::kMaxPacketSize);
  b.resize(bridge::encode_hello(h, b.data(), b.size()));
  return b;
}

// The client's clock runs 1000 s ahead of the simulator's: only differences matter.
constexpr double kOffset = 1000.0;

class Inbox : public ::testing::Test {
 protected:
  BridgeVerdict send(const Bytes& b, double recv_time, uint64_t source = kClient) {
    return inbox.accept(b.data(), b.size(), source, recv_time);
  }
  BridgeInbox inbox{0.05, 1.0};
};

TEST_F(Inbox, AcceptsIncreasingSequences) {
  for (uint32_t i = 0; i < 10; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(i, t + kOffset, Vec3(i, 0, 0)), t + 0.0002), BridgeVerdict::AcceptedPose) << i;
    EXPECT_EQ(inbox.packet().pose.sequence, i);
    EXPECT_EQ(inbox.packet().pose.pose.p.x(), i);
  }
  const BridgeCounters c = inbox.counters();
  EXPECT_EQ(c[BridgeVerdict::AcceptedPose], 10u);
  EXPECT_EQ(c.received, 10u);
  EXPECT_EQ(c.rejected(), 0u);
  EXPECT_EQ(c.sessions, 1u);
  EXPECT_EQ(inbox.client(), kClient);
}

TEST_F(Inbox, RejectsDuplicatesAndOutOfOrder) {
  ASSERT_EQ(send(pose(5, kOffset), 0.0), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(send(pose(5, kOffset + 0.001), 0.001), BridgeVerdict::Duplicate);
  EXPECT_EQ(send(pose(4, kOffset + 0.001), 0.001), BridgeVerdict::OutOfOrder);
  EXPECT_EQ(send(pose(7, kOffset + 0.002), 0.002), BridgeVerdict::AcceptedPose);  // gaps are fine
  EXPECT_EQ(send(pose(6, kOffset + 0.002), 0.0025), BridgeVerdict::OutOfOrder);
  const BridgeCounters c = inbox.counters();
  EXPECT_EQ(c[BridgeVerdict::Duplicate], 1u);
  EXPECT_EQ(c[BridgeVerdict::OutOfOrder], 2u);
  EXPECT_EQ(c[BridgeVerdict::AcceptedPose], 2u);
  EXPECT_EQ(c.rejected(), 3u);
}

TEST_F(Inbox, SequenceNumbersMayWrap) {
  ASSERT_EQ(send(pose(0xfffffffeu, kOffset), 0.0), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(send(pose(0xffffffffu, kOffset + 0.001), 0.001), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(send(pose(0u, kOffset + 0.002), 0.002), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(send(pose(0xffffffffu, kOffset + 0.003), 0.003), BridgeVerdict::OutOfOrder);
}

TEST_F(Inbox, RejectsPacketsDelayedBeyondTheTimeout) {
  // Steady stream with 0.2 ms transit; then one packet that spent 80 ms in transit (stale), one
  // that spent 40 ms (fine).
  uint32_t seq = 0;
  for (int i = 0; i < 20; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose);
  }
  EXPECT_EQ(send(pose(seq++, kOffset + 0.020), 0.100), BridgeVerdict::Stale);
  EXPECT_EQ(send(pose(seq++, kOffset + 0.061), 0.101), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(inbox.counters()[BridgeVerdict::Stale], 1u);
}

TEST_F(Inbox, ToleratesSlowClockDrift) {
  // The client's clock runs 500 ppm slow over 10 s of packets at 1 kHz: nothing is stale.
  uint32_t seq = 0;
  for (int i = 0; i < 10000; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t * (1.0 - 5e-4)), t + 0.0001), BridgeVerdict::AcceptedPose) << i;
  }
}

TEST_F(Inbox, RefusesForeignClientsWhileTheSessionLives) {
  ASSERT_EQ(send(pose(1, kOffset), 0.0), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(send(pose(100, kOffset + 0.5), 0.5, kOther), BridgeVerdict::Foreign);
  EXPECT_EQ(send(hello(200, kOffset + 0.5), 0.5, kOther), BridgeVerdict::Foreign);
  ASSERT_EQ(send(pose(2, kOffset + 0.9), 0.9), BridgeVerdict::AcceptedPose);
  // After a second of silence another client may take over, with its own sequence numbers.
  EXPECT_EQ(send(pose(3, 7.0), 2.0, kOther), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(inbox.client(), kOther);
  EXPECT_EQ(send(pose(3, kOffset + 2.0), 2.0), BridgeVerdict::Foreign);
  const BridgeCounters c = inbox.counters();
  EXPECT_EQ(c[BridgeVerdict::Foreign], 3u);
  EXPECT_EQ(c.sessions, 2u);
}

TEST_F(Inbox, AHelloStartsANewSession) {
  ASSERT_EQ(send(pose(500, kOffset), 0.0), BridgeVerdict::AcceptedPose);
  // The client restarted: its counter starts over, after a hello.
  EXPECT_EQ(send(pose(1, kOffset + 0.01), 0.01), BridgeVerdict::OutOfOrder);
  EXPECT_EQ(send(hello(0, kOffset + 0.02), 0.02), BridgeVerdict::AcceptedHello);
  EXPECT_DOUBLE_EQ(inbox.packet().hello.max_force, 5.0);
  EXPECT_EQ(send(pose(1, kOffset + 0.03), 0.03), BridgeVerdict::AcceptedPose);
  EXPECT_EQ(inbox.counters().sessions, 2u);
}

// One packet whose client time is 0.2 s ahead is accepted without moving the clock offset, so the
// packets after it are not judged 0.2 s late (Stale) and the stream goes on (lowering the offset
// would leave about 2 s without force, until the session timed out).
TEST_F(Inbox, OneClientTimeAheadDoesNotStallTheStream) {
  uint32_t seq = 0;
  for (int i = 0; i < 20; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose);
  }
  EXPECT_EQ(send(pose(seq++, kOffset + 0.020 + 0.2), 0.0202), BridgeVerdict::AcceptedPose);
  for (int i = 21; i < 200; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose) << "packet " << i;
  }
  EXPECT_EQ(inbox.counters().rejected(), 0u);
}

// A sequence number leaping 2^31 - 1 ahead used to be believed, and every following packet was then
// OutOfOrder until the session timed out. Now the leap is rejected and the stream goes on.
TEST_F(Inbox, OneSequenceLeapDoesNotStallTheStream) {
  uint32_t seq = 100;
  for (int i = 0; i < 20; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose);
  }
  EXPECT_EQ(send(pose(seq + 0x7fffffffu, kOffset + 0.020), 0.0202), BridgeVerdict::OutOfOrder);
  EXPECT_EQ(send(pose(seq + 0x80000000u, kOffset + 0.0205), 0.0207), BridgeVerdict::OutOfOrder);
  for (int i = 21; i < 200; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose) << "packet " << i;
  }
  EXPECT_EQ(inbox.counters().resyncs, 0u);
}

// A client whose counter really jumped by 2^31 (restarted without a hello) is followed after three
// packets that agree with each other, instead of being refused until the session times out.
TEST_F(Inbox, ASequenceThatReallyJumpedIsFollowed) {
  uint32_t seq = 5;
  for (int i = 0; i < 20; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose);
  }
  seq += 0x80000000u;
  EXPECT_EQ(send(pose(seq++, kOffset + 0.020), 0.0202), BridgeVerdict::OutOfOrder);
  EXPECT_EQ(send(pose(seq++, kOffset + 0.021), 0.0212), BridgeVerdict::OutOfOrder);
  EXPECT_EQ(send(pose(seq++, kOffset + 0.022), 0.0222), BridgeVerdict::AcceptedPose);
  for (int i = 23; i < 100; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose) << "packet " << i;
  }
  EXPECT_EQ(inbox.counters().resyncs, 1u);
  EXPECT_EQ(inbox.counters().sessions, 1u);
}

// A client clock that steps back 0.2 s makes every packet look late: rejected for a little over the
// timeout (a transient delay stays rejected), then followed. Before: about 1 s (the session timeout).
TEST_F(Inbox, AClockThatSteppedBackIsFollowedAfterTheTimeout) {
  uint32_t seq = 0;
  for (int i = 0; i < 20; ++i) {
    const double t = 0.001 * i;
    ASSERT_EQ(send(pose(seq++, kOffset + t), t + 0.0002), BridgeVerdict::AcceptedPose);
  }
  int rejected = 0;
  for (int i = 20; i < 300; ++i) {
    const double t = 0.001 * i;
    if (send(pose(seq++, kOffset + t - 0.2), t + 0.0002) != BridgeVerdict::AcceptedPose) {
      ++rejected;
      ASSERT_LT(i, 100) << "still rejected " << (i - 20) << " ms after the step";
    }
  }
  EXPECT_GE(rejected, 40);
  EXPECT_LE(rejected, 60);
  EXPECT_EQ(inbox.counters().resyncs, 1u);
}

TEST_F(Inbox, CountsEveryParseRejection) {
  const Bytes good = pose(1, kOffset);
  Bytes truncated(good.begin(), good.begin() + 20);
  Bytes malformed = good;
  malformed.push_back(0);
  Bytes magic = good;
  magic[1] = 0;
  Bytes version = good;
  version[4] = 9;
  const Bytes non_finite = pose(1, kOffset, Vec3(std::nan(""), 0, 0));
  Bytes non_unit = good;
  non_unit[55] = 0x40;  // qw = 65536
  for (const Bytes* b :
       std::initializer_list<const Bytes*>{&truncated, &malformed, &magic, &version, &non_finite, &non_unit})
    EXPECT_NE(send(*b, 0.0), BridgeVerdict::AcceptedPose);
  inbox.count(BridgeVerdict::Malformed);  // e.g. an oversized datagram seen by the receiver
  const BridgeCounters c = inbox.counters();
  EXPECT_EQ(c[BridgeVerdict::Truncated], 1u);
  EXPECT_EQ(c[BridgeVerdict::Malformed], 2u);
  EXPECT_EQ(c[BridgeVerdict::BadMagic], 1u);
  EXPECT_EQ(c[BridgeVerdict::BadVersion], 1u);
  EXPECT_EQ(c[BridgeVerdict::NonFinite], 1u);
  EXPECT_EQ(c[BridgeVerdict::NonUnit], 1u);
  EXPECT_EQ(c.rejected(), 7u);
  EXPECT_EQ(c.sessions, 0u);  // rejected packets start nothing
  // Then a good one is still accepted.
  EXPECT_EQ(send(good, 0.001), BridgeVerdict::AcceptedPose);
}

TEST(BridgeVerdictNames, AreDistinct) {
  for (std::size_t a = 0; a < kBridgeVerdictCount; ++a)
    for (std::size_t b = a + 1; b < kBridgeVerdictCount; ++b)
      EXPECT_STRNE(bridge_verdict_name(static_cast<BridgeVerdict>(a)),
                   bridge_verdict_name(static_cast<BridgeVerdict>(b)));
}

}  // namespace
}  // namespace cariesim
