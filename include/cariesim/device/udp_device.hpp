#pragma once
/// The UDP bridge device (`udp:PORT[:HOST]`, docs/device-bridge.md). A receiver thread parses client
/// datagrams strictly (BridgeInbox) and hands the newest valid pose to the servo thread through a
/// TripleBuffer; the servo thread's write() hands the wrench to a sender thread through another
/// TripleBuffer and wakes it; a hello's limits (or their withdrawal when a new client comes without
/// one) reach the servo thread through a third (poll_limits). The servo thread never touches the
/// socket, never locks, never allocates. The bridge sends the wrench it is given (the servo loop's
/// Params, tightened to the announced limits, bound it), but only as many as the client sent
/// packets and only while it keeps sending (ReplyBudget).

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/common/lockfree.hpp"
#include "cariesim/device/device.hpp"
#include "cariesim/device/input_guard.hpp"
#include "cariesim/device/udp_protocol.hpp"

namespace cariesim {

/// What the bridge did with one datagram.
enum class BridgeVerdict : uint8_t {
  AcceptedPose,   ///< a new pose for the servo thread
  AcceptedHello,  ///< device limits; a new session began
  Truncated,      ///< rejected: shorter than its header or type needs
  Malformed,      ///< rejected: too long, unknown type/flags, reserved bytes set, values out of range
  BadMagic,       ///< rejected: not this protocol
  BadVersion,     ///< rejected: another protocol version
  NonFinite,      ///< rejected: a NaN or infinite number
  NonUnit,        ///< rejected: the quaternion is not unit (is_unit: within kUnitTolerance)
  Duplicate,      ///< rejected: the sequence number was seen last
  OutOfOrder,     ///< rejected: older than the newest accepted sequence number
  Stale,          ///< rejected: delayed in transit by more than the timeout
  Foreign,        ///< rejected: another address while a session with a client is alive
};
inline constexpr std::size_t kBridgeVerdictCount = 12;
/// "accepted_pose", "rejected_truncated", ...
const char* bridge_verdict_name(BridgeVerdict verdict);

/// The bridge's counters: datagrams by verdict, and the sender's packets.
struct BridgeCounters {
  std::array<uint64_t, kBridgeVerdictCount> by_verdict{};  ///< indexed by BridgeVerdict
  uint64_t received = 0;                                   ///< datagrams read from the socket
  uint64_t sent = 0;                                       ///< wrench packets sent
  uint64_t send_errors = 0;                                ///< sendto failures
  /// Wrenches not sent: the client was silent for the session timeout, or as many wrenches as it
  /// sent packets within the last timeout already went out (ReplyBudget).
  uint64_t withheld = 0;
  uint64_t sessions = 0;  ///< sessions started (first packet, hello, or a new client after a silence)
  uint64_t resyncs = 0;   ///< times the session followed a client whose sequence or clock jumped

  [[nodiscard]] uint64_t operator[](BridgeVerdict v) const { return by_verdict[static_cast<std::size_t>(v)]; }
  /// Datagrams rejected for any reason.
  [[nodiscard]] uint64_t rejected() const;
};

/// The strict, stateful acceptance of client datagrams, without sockets (the receiver thread's
/// logic; tests drive it directly). One thread calls accept(); counters() may be called from any.
///
/// A session belongs to one client address. It starts with the first valid packet, with a hello, or
/// when a packet arrives after `session_timeout` of silence; packets from another address while it
/// lives are Foreign. Within a session sequence numbers must increase (serial arithmetic, so they may
/// wrap). A packet is Stale when its transit delay exceeds the timeout: the delay is measured as
/// (receive time - client time) minus the smallest such difference seen in the session, which
/// absorbs the offset between the two clocks (and a drift of up to 0.1 %).
///
/// One bad packet cannot stall a session: a sequence number more than 2^16 ahead is rejected
/// (OutOfOrder) instead of believed, and a single packet whose client time leapt ahead is accepted
/// without moving the clock offset. A client whose sequence or clock really jumped (three packets in
/// a row that agree with each other and not with the session; for a late clock, over more than the
/// timeout) is followed: the session resynchronises (BridgeCounters::resyncs) instead of refusing
/// every packet until the session times out.
class BridgeInbox {
 public:
  /// `timeout` (s): the largest accepted transit delay; `session_timeout` (s): silence that ends a
  /// session.
  explicit BridgeInbox(double timeout = InputLimits{}.stale_after, double session_timeout = 1.0);
  /// Judges one datagram from `source` (an opaque address key, not 0) received at `recv_time` (s,
  /// any monotonic clock). On AcceptedPose/AcceptedHello, packet() holds it.
  BridgeVerdict accept(const uint8_t* data, std::size_t size, uint64_t source, double recv_time);
  /// Counts a datagram rejected before parsing (e.g. larger than any packet: Malformed).
  void count(BridgeVerdict verdict);
  /// The packet accepted last.
  [[nodiscard]] const bridge::ClientPacket& packet() const { return packet_; }
  /// The current session's client address key (0 before the first packet).
  [[nodiscard]] uint64_t client() const { return client_; }
  /// Sessions started so far (the receiver's thread; BridgeCounters::sessions for any thread).
  [[nodiscard]] uint64_t session_count() const { return sessions_.load(std::memory_order_relaxed); }
  /// Datagrams by verdict and sessions (any thread).
  [[nodiscard]] BridgeCounters counters() const;
  /// Ends the session (the next valid packet from anyone starts one).
  void reset_session() { session_alive_ = false; }

 private:
  BridgeVerdict judge(const uint8_t* data, std::size_t size, uint64_t source, double recv_time);
  double timeout_, session_timeout_;
  bridge::ClientPacket packet_;
  uint64_t client_ = 0;
  bool session_alive_ = false;
  uint32_t last_sequence_ = 0;
  double last_accept_time_ = 0.0;  // s
  double clock_offset_ = 0.0;      // s, smallest (recv_time - client_time) of the session
  int note_disagreeing(uint32_t sequence, double offset, double recv_time);
  // The run of consecutive packets that disagree with the session (resynchronisation).
  int run_packets_ = 0;
  uint32_t run_sequence_ = 0;  // the run's last sequence number
  double run_offset_ = 0.0;    // s, smallest clock offset in the run
  double run_started_ = 0.0;   // s, receive time of the run's first packet
  std::atomic<uint64_t> resyncs_{0};
  std::array<std::atomic<uint64_t>, kBridgeVerdictCount> counts_{};
  std::atomic<uint64_t> sessions_{0};
};

/// Which wrenches the bridge may send (docs/device-bridge.md, "Replies"): each packet accepted from
/// the client is answered at most once (by the next wrench the servo loop writes after it), and only
/// within `window` (the session timeout) of it. So the bridge never sends more packets than it
/// received within the last timeout, and one datagram, spoofed or not, gets one wrench back instead
/// of making the station a reflector. The receiver thread notes each accepted packet, the sender
/// thread asks before each wrench. Lock-free and allocation-free.
class ReplyBudget {
 public:
  /// `window` (s): the session timeout.
  explicit ReplyBudget(double window = 1.0);
  /// Forgets every packet and reply (no thread may use the budget meanwhile).
  void reset();
  /// A packet was accepted from the client at `now_ns` (CLOCK_MONOTONIC ns). One thread.
  void received(int64_t now_ns);
  /// Whether a wrench answering the pose with sequence number `echo` may go out at `now_ns`: that
  /// pose was not answered by the last wrench that went out, fewer wrenches than accepted packets went
  /// out, and the last packet was accepted at most `window` ago. Counts the wrench when so. Charging
  /// the pose a wrench answers (not just any packet) lets the newest pose be answered although a
  /// wrench for the one before went out after it arrived. One (other) thread.
  bool take(int64_t now_ns, uint32_t echo);

 private:
  int64_t window_ns_;
  std::atomic<uint64_t> received_{0};      // packets accepted so far
  std::atomic<int64_t> last_received_ns_;  // when the last one was
  uint64_t sent_ = 0;                      // the sender's thread only: wrenches that went out
  std::optional<uint32_t> last_echo_;      // the sender's thread only: the pose the last one answered
};

/// Settings of the UDP device.
struct UdpOptions {
  uint16_t port = 47000;           ///< UDP port to listen on (0: any free port, see UdpDevice::port())
  std::string host = "127.0.0.1";  ///< address to bind ("0.0.0.0" for every interface)
  /// s, largest transit delay of an accepted pose: the staleness readings are judged by
  /// (InputLimits::stale_after, which the device factory passes)
  double timeout = InputLimits{}.stale_after;
  double session_timeout = 1.0;    ///< s, silence after which another client may connect
  /// What info() reports until a hello announces the device's own limits (the factory passes the
  /// scene's). The bridge itself enforces nothing: the servo loop tightens its Params to a hello's.
  DeviceLimits limits;
  Pose home;  ///< reported before the first pose arrives
  /// SCHED_FIFO priority asked for the receiver and sender threads (1-99; 0: normal priority). Below
  /// the servo thread's 80 by default, above everything else, so a loaded machine does not delay
  /// the poses and wrenches; when refused the threads run at normal priority (see realtime_status()).
  int realtime_priority = 70;
};

class UdpDevice : public Device {
 public:
  explicit UdpDevice(const UdpOptions& options);
  ~UdpDevice() override;
  UdpDevice(const UdpDevice&) = delete;
  UdpDevice& operator=(const UdpDevice&) = delete;

  /// name "udp", the address (and the remote device's name after a hello), the limits the client
  /// announced last (UdpOptions::limits before a hello).
  [[nodiscard]] DeviceInfo info() const override;
  /// Binds the socket and starts the receiver and sender threads; throws cariesim::Error naming the
  /// address when the socket cannot be bound.
  void start() override;
  void stop() override;
  DeviceState read(double now) override;
  void write(const Vec3& force, const Vec3& torque) override;
  void set_status(const DeviceStatus& status) override;
  /// A hello's limits (as announced; the resolution, which a hello does not carry, as 0), once; or,
  /// once, that they were withdrawn: a session began with a packet from another client than the one
  /// whose hello was announced last, without a hello of its own.
  bool poll_limits(LimitsAnnouncement& out) override;
  [[nodiscard]] std::vector<DeviceCounter> counters() const override;
  /// The counters as a struct (any thread).
  [[nodiscard]] BridgeCounters bridge_counters() const;
  /// "SCHED_FIFO priority N", "not requested" or why real-time priority was refused (after start()).
  [[nodiscard]] std::string realtime_status() const;
  /// The bound port (after start()).
  [[nodiscard]] uint16_t port() const { return bound_port_.load(); }

 private:
  /// A pose as handed from the receiver to the servo thread.
  struct Inbound {
    Pose pose;
    Vec3 velocity = Vec3::Zero();
    Vec3 angular_velocity = Vec3::Zero();
    uint32_t buttons = 0;
    uint32_t packet_sequence = 0;
    double client_time = 0.0;  // s, client clock
    int64_t received_ns = 0;   // CLOCK_MONOTONIC
    uint64_t count = 0;        // accepted poses so far
  };
  void receive_loop();
  void send_loop(uint32_t seen);
  /// Receiver: tells the servo thread the announced limits no longer hold; info() reports UdpOptions'.
  void withdraw_limits();  // `seen`: the wrench ticket when start() made the thread

  UdpOptions options_;
  int socket_ = -1;
  std::atomic<bool> running_{false};
  std::atomic<uint16_t> bound_port_{0};
  std::thread receiver_, sender_;
  BridgeInbox inbox_;
  uint64_t accepted_ = 0;                        // receiver thread
  TripleBuffer<Inbound> inbound_;                // receiver -> servo
  TripleBuffer<bridge::WrenchPacket> outbound_;  // servo -> sender
  TripleBuffer<LimitsAnnouncement> announced_limits_;  // receiver -> servo, per hello or withdrawal
  uint64_t hello_client_ = 0;                          // receiver: whose hello is announced (0: none)
  uint64_t session_seen_ = 0;                          // receiver: the inbox's sessions so far
  ReplyBudget budget_;                                 // receiver notes, sender takes
  std::atomic<uint32_t> outbound_ticket_{0};     // bumped per write; the sender waits on it
  std::atomic<uint64_t> client_address_{0};      // IPv4 address << 16 | port (network order); 0 = none
  std::atomic<uint64_t> sent_{0}, send_errors_{0}, withheld_{0};
  std::string realtime_status_;    // set by start(), read under info_mutex_
  mutable std::mutex info_mutex_;  // guards announced_ and remote_name_ (never the servo thread's)
  DeviceLimits announced_;         // what info() reports
  std::string remote_name_;
  // Servo thread only.
  Inbound latest_;
  bool have_pose_ = false;
  double last_now_ = 0.0;
  DeviceStatus status_;
};

}  // namespace cariesim
