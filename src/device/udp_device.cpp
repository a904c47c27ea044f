#include "cariesim/device/udp_device.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/cpu.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/safety.hpp"

namespace cariesim {

namespace {

// The wrench packet's flags (the protocol's own word) for a cycle's status: the step's clamps, what
// force safety did, whether announced limits are in force.
uint16_t wrench_flags(const DeviceStatus& status) {
  uint16_t flags = 0;
  const auto set = [&](bool on, uint16_t bit) {
    if (on) flags |= bit;
  };
  set(status.force_clamped, bridge::kWrenchForceClamped);
  set(status.torque_clamped, bridge::kWrenchTorqueClamped);
  set((status.safety_flags & kSafetyRamping) != 0, bridge::kWrenchRamping);
  set((status.safety_flags & kSafetyStale) != 0, bridge::kWrenchInputStale);
  set((status.safety_flags & kSafetyNonFinite) != 0, bridge::kWrenchInputNonFinite);
  set((status.safety_flags & kSafetyInvalidInput) != 0, bridge::kWrenchInputInvalid);
  set((status.safety_flags & kSafetyJump) != 0, bridge::kWrenchInputJump);
  set(status.limits_acknowledged, bridge::kWrenchLimitsAcknowledged);
  return flags;
}

// The drift between client and simulator clocks that the staleness test absorbs (0.1 %).
constexpr double kDriftAllowance = 1e-3;
// A sequence number further ahead than this within a live session is not believed from one packet
// (at 10 kHz it is 6.5 s of packets, far beyond the session timeout).
constexpr int32_t kMaxSequenceJump = 1 << 16;
// Consecutive packets that agree with each other (increasing sequence numbers, clock offsets within
// the timeout) and disagree with the session: after this many the session adopts them.
constexpr int kResyncPackets = 3;
// How long the receiver blocks in recvfrom before it looks at the running flag again.
constexpr long kReceivePollUs = 20000;

uint64_t address_key(const sockaddr_in& a) {
  return (static_cast<uint64_t>(a.sin_addr.s_addr) << 16) | a.sin_port;
}

sockaddr_in address_from_key(uint64_t key) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = static_cast<in_port_t>(key & 0xffffu);
  a.sin_addr.s_addr = static_cast<in_addr_t>(key >> 16);
  return a;
}

// Serial-number comparison (RFC 1982 style): > 0 when `a` is newer than `b`.
int32_t sequence_diff(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b); }

BridgeVerdict verdict_of(bridge::ParseResult r) {
  switch (r) {
    case bridge::ParseResult::Pose:
      return BridgeVerdict::AcceptedPose;
    case bridge::ParseResult::Hello:
      return BridgeVerdict::AcceptedHello;
    case bridge::ParseResult::Truncated:
      return BridgeVerdict::Truncated;
    case bridge::ParseResult::BadMagic:
      return BridgeVerdict::BadMagic;
    case bridge::ParseResult::BadVersion:
      return BridgeVerdict::BadVersion;
    case bridge::ParseResult::NonFinite:
      return BridgeVerdict::NonFinite;
    case bridge::ParseResult::NonUnit:
      return BridgeVerdict::NonUnit;
    case bridge::ParseResult::Wrench:
    case bridge::ParseResult::Malformed:
      return BridgeVerdict::Malformed;
  }
  return BridgeVerdict::Malformed;
}

}  // namespace

const char* bridge_verdict_name(BridgeVerdict verdict) {
  switch (verdict) {
    case BridgeVerdict::AcceptedPose:
      return "accepted_pose";
    case BridgeVerdict::AcceptedHello:
      return "accepted_hello";
    case BridgeVerdict::Truncated:
      return "rejected_truncated";
    case BridgeVerdict::Malformed:
      return "rejected_malformed";
    case BridgeVerdict::BadMagic:
      return "rejected_bad_magic";
    case BridgeVerdict::BadVersion:
      return "rejected_bad_version";
    case BridgeVerdict::NonFinite:
      return "rejected_non_finite";
    case BridgeVerdict::NonUnit:
      return "rejected_non_unit";
    case BridgeVerdict::Duplicate:
      return "rejected_duplicate";
    case BridgeVerdict::OutOfOrder:
      return "rejected_out_of_order";
    case BridgeVerdict::Stale:
      return "rejected_stale";
    case BridgeVerdict::Foreign:
      return "rejected_foreign";
  }
  return "unknown";
}

uint64_t BridgeCounters::rejected() const {
  uint64_t n = 0;
  for (std::size_t v = static_cast<std::size_t>(BridgeVerdict::Truncated); v < kBridgeVerdictCount; ++v)
    n += by_verdict[v];
  return n;
}

BridgeInbox::BridgeInbox(double timeout, double session_timeout)
    : timeout_(timeout), session_timeout_(session_timeout) {}

void BridgeInbox::count(BridgeVerdict verdict) {
  // Single writer: a relaxed load and store is race-free and cheaper than fetch_add.
  auto& c = counts_[static_cast<std::size_t>(verdict)];
  c.store(c.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

BridgeVerdict BridgeInbox::accept(const uint8_t* data, std::size_t size, uint64_t source, double recv_time) {
  const BridgeVerdict v = judge(data, size, source, recv_time);
  count(v);
  return v;
}

BridgeVerdict BridgeInbox::judge(const uint8_t* data, std::size_t size, uint64_t source, double recv_time) {
  // Strict parse first: a datagram that is not a valid packet changes nothing.
  const BridgeVerdict parsed = verdict_of(bridge::parse_client_packet(data, size, packet_));
  if (parsed != BridgeVerdict::AcceptedPose && parsed != BridgeVerdict::AcceptedHello) return parsed;
  const bool hello = parsed == BridgeVerdict::AcceptedHello;
  const uint32_t sequence = hello ? packet_.hello.sequence : packet_.pose.sequence;
  const double client_time = hello ? packet_.hello.client_time : packet_.pose.client_time;

  // A session lives while its client keeps sending; meanwhile other addresses are refused.
  if (session_alive_ && recv_time - last_accept_time_ > session_timeout_) session_alive_ = false;
  if (session_alive_ && source != client_) return BridgeVerdict::Foreign;

  // A hello, or the first packet after a silence, starts a session: any sequence number is fine and
  // the clock offset is measured afresh.
  const double offset_sample = recv_time - client_time;
  if (hello || !session_alive_) {
    session_alive_ = true;
    client_ = source;
    clock_offset_ = offset_sample;
    run_packets_ = 0;
    sessions_.store(sessions_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  } else {
    // Within a session: increasing sequence numbers (no implausible leap ahead), bounded transit
    // delay. The delay is measured against the smallest clock offset seen, relaxed by the drift.
    const int32_t d = sequence_diff(sequence, last_sequence_);
    if (d == 0) return BridgeVerdict::Duplicate;
    const double relaxed_offset =
        clock_offset_ + kDriftAllowance * std::max(recv_time - last_accept_time_, 0.0);
    const double lateness = offset_sample - relaxed_offset;  // s, > 0: later than the fastest packet
    const bool in_order = d > 0 && d <= kMaxSequenceJump;
    const bool stale = lateness > timeout_;
    if (in_order && !stale) {
      // A packet far earlier than any before (its client clock leapt ahead) is fresh, but one such
      // packet does not move the offset: only a run of them does (the clock really jumped).
      if (lateness < -timeout_) {
        if (note_disagreeing(sequence, offset_sample, recv_time) >= kResyncPackets) {
          clock_offset_ = run_offset_;
          run_packets_ = 0;
        }
      } else {
        clock_offset_ = std::min(relaxed_offset, offset_sample);
        run_packets_ = 0;
      }
    } else {
      // Rejected, unless it completes a run of packets that agree with each other: the client's
      // sequence numbers or clock jumped (one bad packet, or a restart without a hello), and the
      // session follows it instead of refusing it until it falls silent. A late run must also last
      // longer than the timeout, so a burst delayed in transit stays rejected.
      const int run = note_disagreeing(sequence, offset_sample, recv_time);
      const bool resync = run >= kResyncPackets && (in_order ? recv_time - run_started_ >= timeout_ : !stale);
      if (!resync) return in_order ? BridgeVerdict::Stale : BridgeVerdict::OutOfOrder;
      clock_offset_ = run_offset_;
      run_packets_ = 0;
      resyncs_.store(resyncs_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    }
  }
  last_sequence_ = sequence;
  last_accept_time_ = recv_time;
  return parsed;
}

// Extends the run of packets that disagree with the session when this one agrees with the run's last
// (sequence number after it, clock offset within the timeout of the run's), else starts a new run.
// Returns the run's length.
int BridgeInbox::note_disagreeing(uint32_t sequence, double offset, double recv_time) {
  const int32_t d = sequence_diff(sequence, run_sequence_);
  const bool continues =
      run_packets_ > 0 && d > 0 && d <= kMaxSequenceJump && std::abs(offset - run_offset_) <= timeout_;
  if (continues) {
    ++run_packets_;
    run_offset_ = std::min(run_offset_, offset);
  } else {
    run_packets_ = 1;
    run_offset_ = offset;
    run_started_ = recv_time;
  }
  run_sequence_ = sequence;
  return run_packets_;
}

BridgeCounters BridgeInbox::counters() const {
  BridgeCounters c;
  for (std::size_t v = 0; v < kBridgeVerdictCount; ++v)
    c.by_verdict[v] = counts_[v].load(std::memory_order_relaxed);
  c.sessions = sessions_.load(std::memory_order_relaxed);
  c.resyncs = resyncs_.load(std::memory_order_relaxed);
  for (uint64_t n : c.by_verdict) c.received += n;
  return c;
}

ReplyBudget::ReplyBudget(double window)
    : window_ns_(static_cast<int64_t>(window * 1e9)),
      last_received_ns_(std::numeric_limits<int64_t>::min()) {}

void ReplyBudget::reset() {
  received_.store(0, std::memory_order_relaxed);
  last_received_ns_.store(std::numeric_limits<int64_t>::min(), std::memory_order_relaxed);
  sent_ = 0;
  last_echo_.reset();
}

void ReplyBudget::received(int64_t now_ns) {
  // The time first, then the count (release): a sender that sees the count sees the time.
  last_received_ns_.store(now_ns, std::memory_order_relaxed);
  received_.fetch_add(1, std::memory_order_release);
}

bool ReplyBudget::take(int64_t now_ns, uint32_t echo) {
  // A pose not answered yet, no more wrenches than packets, the last packet within the window.
  const uint64_t received = received_.load(std::memory_order_acquire);
  if (sent_ >= received || last_echo_ == echo) return false;
  const int64_t last = last_received_ns_.load(std::memory_order_relaxed);
  if (now_ns - last > window_ns_) return false;
  ++sent_;
  last_echo_ = echo;
  return true;
}

UdpDevice::UdpDevice(const UdpOptions& options)
    : options_(options),
      inbox_(options.timeout, options.session_timeout),
      budget_(options.session_timeout),
      announced_(options.limits) {
  latest_.pose = options.home;
}

UdpDevice::~UdpDevice() { stop(); }

DeviceInfo UdpDevice::info() const {
  DeviceInfo info;
  info.name = "udp";
  std::lock_guard<std::mutex> lock(info_mutex_);
  info.description =
      options_.host + ":" + std::to_string(bound_port_.load() ? bound_port_.load() : options_.port);
  if (!remote_name_.empty()) info.description += " (" + remote_name_ + ")";
  info.limits = announced_;
  info.renders_force = true;
  return info;
}

void UdpDevice::start() {
  if (running_.load()) return;
  // Resolve the bind address (IPv4) and bind a datagram socket.
  const std::string where = "udp:" + std::to_string(options_.port) + ":" + options_.host;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (const int rc = getaddrinfo(options_.host.c_str(), nullptr, &hints, &found); rc != 0 || found == nullptr)
    throw Error(where + ": cannot resolve host '" + options_.host + "': " + gai_strerror(rc));
  sockaddr_in bind_address{};
  std::memcpy(&bind_address, found->ai_addr, sizeof(bind_address));
  freeaddrinfo(found);
  bind_address.sin_port = htons(options_.port);
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (socket_ < 0) throw Error(where + ": cannot create a UDP socket: " + std::strerror(errno));
  if (::bind(socket_, reinterpret_cast<const sockaddr*>(&bind_address), sizeof(bind_address)) != 0) {
    const int err = errno;
    ::close(socket_);
    socket_ = -1;
    throw Error(where + ": cannot bind: " + std::strerror(err));
  }
  // The receiver wakes up regularly to notice stop().
  timeval poll{0, kReceivePollUs};
  setsockopt(socket_, SOL_SOCKET, SO_RCVTIMEO, &poll, sizeof(poll));
  sockaddr_in bound{};
  socklen_t bound_size = sizeof(bound);
  getsockname(socket_, reinterpret_cast<sockaddr*>(&bound), &bound_size);
  bound_port_.store(ntohs(bound.sin_port));

  // A new start is a new session: forget the old client, pose and wrench (no thread runs yet).
  inbox_.reset_session();
  client_address_.store(0);
  have_pose_ = false;
  latest_ = Inbound{};
  Inbound old_pose;
  inbound_.read(old_pose);
  bridge::WrenchPacket old_wrench;
  outbound_.read(old_wrench);
  LimitsAnnouncement old_limits;
  announced_limits_.read(old_limits);
  hello_client_ = 0;
  session_seen_ = inbox_.session_count();
  budget_.reset();
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    announced_ = options_.limits;
    remote_name_.clear();
  }
  latest_.pose = options_.home;
  running_.store(true);
  // Logged before the threads start, so spdlog's default logger (created lazily by the first call)
  // exists before the receiver can log too.
  spdlog::debug("udp device listening on {}:{}", options_.host, bound_port_.load());
  receiver_ = std::thread([this] { receive_loop(); });
  // The sender starts from the ticket as it is now, before any write() or stop() can bump it: a
  // sender thread scheduled late still sends the first wrench instead of waiting for the second.
  const uint32_t ticket = outbound_ticket_.load();
  sender_ = std::thread([this, ticket] { send_loop(ticket); });

  // Real-time priority for both threads when asked and allowed: under load a normal-priority thread
  // can wait milliseconds to be scheduled, and every such delay ages the pose or drops a wrench.
  std::string status = "not requested (normal priority)";
  if (options_.realtime_priority > 0) {
    int rc = set_fifo_priority(receiver_.native_handle(), options_.realtime_priority);
    if (rc == 0) rc = set_fifo_priority(sender_.native_handle(), options_.realtime_priority);
    status = rc == 0
                 ? "SCHED_FIFO priority " + std::to_string(clamp_fifo_priority(options_.realtime_priority))
                 : std::string("refused: ") + std::strerror(rc) + "; normal priority";
    if (rc != 0) spdlog::warn("udp device: real-time priority for the bridge threads {}", status);
  }
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    realtime_status_ = status;
  }
}

void UdpDevice::stop() {
  if (!running_.exchange(false)) return;
  // Wake the sender; the receiver notices within one receive timeout.
  outbound_ticket_.fetch_add(1);
  outbound_ticket_.notify_all();
  receiver_.join();
  sender_.join();
  ::close(socket_);
  socket_ = -1;
}

void UdpDevice::receive_loop() {
  // One buffer larger than any packet, so oversized datagrams are seen (and rejected) whole.
  std::array<uint8_t, 2048> buffer{};
  while (running_.load(std::memory_order_relaxed)) {
    sockaddr_in from{};
    socklen_t from_size = sizeof(from);
    const ssize_t n = ::recvfrom(socket_, buffer.data(), buffer.size(), MSG_TRUNC,
                                 reinterpret_cast<sockaddr*>(&from), &from_size);
    if (n < 0) continue;  // timeout (to look at running_) or a transient error
    const int64_t now_ns = monotonic_ns();
    if (static_cast<std::size_t>(n) > buffer.size()) {
      inbox_.count(BridgeVerdict::Malformed);
      continue;
    }
    const uint64_t source = address_key(from);
    const BridgeVerdict v =
        inbox_.accept(buffer.data(), static_cast<std::size_t>(n), source, static_cast<double>(now_ns) * 1e-9);
    if (v != BridgeVerdict::AcceptedPose && v != BridgeVerdict::AcceptedHello) continue;
    // Each accepted packet allows one wrench back (ReplyBudget).
    budget_.received(now_ns);
    const uint64_t session = inbox_.session_count();
    const bool new_session = session != session_seen_;
    session_seen_ = session;
    if (v == BridgeVerdict::AcceptedPose) {
      // A session begun by a pose from another client than the one whose hello is announced: that
      // hello's limits are withdrawn (the scene's apply), before the servo thread sees the pose.
      if (new_session && source != hello_client_) withdraw_limits();
      // Hand the pose to the servo thread and answer this client from now on.
      const bridge::PosePacket& p = inbox_.packet().pose;
      Inbound in;
      in.pose = p.pose;
      in.velocity = p.velocity;
      in.angular_velocity = p.angular_velocity;
      in.buttons = p.buttons;
      in.packet_sequence = p.sequence;
      in.client_time = p.client_time;
      in.received_ns = now_ns;
      in.count = ++accepted_;
      inbound_.write(in);
      client_address_.store(source);
    } else {
      // The device's limits go to the servo thread as announced; it decides what they change.
      const bridge::HelloPacket& h = inbox_.packet().hello;
      DeviceLimits limits;
      limits.max_force = h.max_force;
      limits.max_stiffness = h.max_stiffness;
      limits.max_torque = h.max_torque;
      limits.position_resolution = 0.0;  // not in a hello: the simulator's holds
      limits.workspace = Eigen::AlignedBox3d(h.workspace_min, h.workspace_max);
      announced_limits_.write(LimitsAnnouncement{false, limits});
      hello_client_ = source;
      {
        std::lock_guard<std::mutex> lock(info_mutex_);
        announced_ = limits;
        announced_.position_resolution = options_.limits.position_resolution;
        remote_name_ = std::string(h.name_view());
      }
      client_address_.store(source);
      spdlog::debug("udp device: hello from '{}' ({} N, {} N/mm, {} N·mm)", h.name_view(), h.max_force,
                    h.max_stiffness, h.max_torque);
    }
  }
}

void UdpDevice::withdraw_limits() {
  announced_limits_.write(LimitsAnnouncement{true, options_.limits});
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    const bool had = hello_client_ != 0;
    announced_ = options_.limits;
    remote_name_.clear();
    if (had)
      spdlog::debug("udp device: a new client without a hello: the earlier hello's limits are withdrawn");
  }
  hello_client_ = 0;
}

void UdpDevice::send_loop(uint32_t seen) {
  std::array<uint8_t, bridge::kWrenchSize> buffer{};
  // `seen` is the ticket from before this thread started, so a write() or a stop() that bumped it
  // since is seen by wait() instead of being slept through.
  while (running_.load()) {
    // Sleep until the servo thread writes (or stop() wakes us).
    outbound_ticket_.wait(seen);
    seen = outbound_ticket_.load();
    if (!running_.load()) break;
    bridge::WrenchPacket w;
    if (!outbound_.read(w)) continue;
    const uint64_t client = client_address_.load();
    if (client == 0) continue;
    // Only while the client keeps sending, and never more wrenches than it sent packets.
    if (!budget_.take(monotonic_ns(), w.sequence)) {
      withheld_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    const sockaddr_in to = address_from_key(client);
    const std::size_t size = bridge::encode_wrench(w, buffer.data(), buffer.size());
    if (::sendto(socket_, buffer.data(), size, 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) ==
        static_cast<ssize_t>(size))
      sent_.fetch_add(1, std::memory_order_relaxed);
    else
      send_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

DeviceState UdpDevice::read(double now) {
  // Take the newest pose the receiver handed over, if any.
  if (inbound_.read(latest_)) have_pose_ = true;
  last_now_ = now;
  DeviceState s;
  s.pose = latest_.pose;
  s.velocity = latest_.velocity;
  s.angular_velocity = latest_.angular_velocity;
  s.buttons = latest_.buttons;
  s.sequence = latest_.count;
  s.valid = have_pose_;
  // Its age on the monotonic clock, expressed on the servo clock.
  s.stamp = have_pose_ ? now - static_cast<double>(monotonic_ns() - latest_.received_ns) * 1e-9 : now;
  return s;
}

void UdpDevice::set_status(const DeviceStatus& status) { status_ = status; }

bool UdpDevice::poll_limits(LimitsAnnouncement& out) { return announced_limits_.read(out); }

void UdpDevice::write(const Vec3& force, const Vec3& torque) {
  // The answer to the pose used this cycle: the wrench as given (the servo loop bounded it), with
  // only non-finite numbers, which the protocol forbids, sent as zero.
  bridge::WrenchPacket w;
  w.sequence = latest_.packet_sequence;
  w.client_time = latest_.client_time;
  w.server_time = last_now_;
  w.force = force.allFinite() ? force : Vec3::Zero();
  w.torque = torque.allFinite() ? torque : Vec3::Zero();
  w.state = status_.state;
  w.depth = std::isfinite(status_.depth) ? status_.depth : 0.0;
  w.flags = wrench_flags(status_);
  if (!have_pose_) return;  // nobody to answer yet
  // Hand it to the sender and wake it (a futex wake when it sleeps; no lock).
  outbound_.write(w);
  outbound_ticket_.fetch_add(1, std::memory_order_release);
  outbound_ticket_.notify_one();
}

std::string UdpDevice::realtime_status() const {
  std::lock_guard<std::mutex> lock(info_mutex_);
  return realtime_status_;
}

BridgeCounters UdpDevice::bridge_counters() const {
  BridgeCounters c = inbox_.counters();
  c.sent = sent_.load(std::memory_order_relaxed);
  c.send_errors = send_errors_.load(std::memory_order_relaxed);
  c.withheld = withheld_.load(std::memory_order_relaxed);
  return c;
}

std::vector<DeviceCounter> UdpDevice::counters() const {
  const BridgeCounters c = bridge_counters();
  std::vector<DeviceCounter> out;
  out.push_back({"received", c.received});
  for (std::size_t v = 0; v < kBridgeVerdictCount; ++v)
    out.push_back({bridge_verdict_name(static_cast<BridgeVerdict>(v)), c.by_verdict[v]});
  out.push_back({"sessions", c.sessions});
  out.push_back({"resyncs", c.resyncs});
  out.push_back({"sent", c.sent});
  out.push_back({"send_errors", c.send_errors});
  out.push_back({"withheld", c.withheld});
  return out;
}

}  // namespace cariesim
