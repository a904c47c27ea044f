// cariesim_udp_client: an example client of the UDP device bridge (docs/device-bridge.md). It
// streams a trajectory CSV to a running `cariesim servo --device udp:PORT` (or any program running a
// UdpDevice) at a fixed rate, as a lab device's servo loop would stream its pose, and prints the
// wrenches the simulator sends back. A real device program does the same with the device's pose
// instead of the trajectory, and renders the wrench instead of printing it.
#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/device/udp_protocol.hpp"
#include "cariesim/render/step.hpp"

namespace {

using namespace cariesim;

// A UDP socket connected to the simulator, so it only hears the simulator's answers.
int connect_to(const std::string& host, uint16_t port) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (const int rc = getaddrinfo(host.c_str(), service.c_str(), &hints, &found); rc != 0 || found == nullptr)
    throw Error("cannot resolve '" + host + "': " + gai_strerror(rc));
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || ::connect(fd, found->ai_addr, found->ai_addrlen) != 0) {
    freeaddrinfo(found);
    throw Error("cannot open a UDP socket to " + host + ":" + service + ": " + std::strerror(errno));
  }
  freeaddrinfo(found);
  return fd;
}

// ns between two hellos while none is acknowledged (the simulator not started yet, or it refused the
// limits: then each refusal is counted in its report and the scene's limits apply).
constexpr int64_t kHelloRepeatNs = 500'000'000;

struct Summary {
  uint64_t sent = 0;
  uint64_t hellos = 0;
  uint64_t received = 0;
  uint64_t bad = 0;
  double max_force = 0.0;  // N
  double rtt_sum = 0.0;    // s
  uint32_t last_echo = 0;
};

void print_wrench(const bridge::WrenchPacket& w, double t) {
  std::printf(
      "t=%8.3f echo=%-8u F=(%+7.3f %+7.3f %+7.3f) N |F|=%6.3f N  tau=(%+8.2f %+8.2f %+8.2f) N.mm  %-10s "
      "depth=%.3f mm flags=0x%04x\n",
      t, w.sequence, w.force.x(), w.force.y(), w.force.z(), w.force.norm(), w.torque.x(), w.torque.y(),
      w.torque.z(), state_name(static_cast<InteractionState>(w.state)), w.depth, w.flags);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Streams a trajectory CSV to the cariesim UDP device bridge and prints the wrenches it gets back"};
  std::string file, host = "127.0.0.1", name = "cariesim_udp_client";
  uint16_t port = 47000;
  double rate = 1000.0, duration = 0.0, max_force = 22.0, max_stiffness = 1.0, max_torque = 500.0;
  double print_every = 0.1;
  bool loop = false, velocity = false, quiet = false;
  app.add_option("trajectory", file, "trajectory CSV (t,px,py,pz,qw,qx,qy,qz; s, mm, unit quaternion)")
      ->required();
  app.add_option("--host", host, "simulator host")->capture_default_str();
  app.add_option("--port", port, "simulator UDP port (cariesim servo --device udp:PORT)")
      ->capture_default_str();
  app.add_option("--rate", rate, "poses per second (Hz)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--duration", duration,
                 "seconds to stream (default: the trajectory's length, or forever with --loop)");
  app.add_flag("--loop", loop, "start the trajectory over at its end");
  app.add_flag("--velocity", velocity, "send velocities (finite differences) with every pose");
  app.add_option("--print-every", print_every, "seconds between printed wrenches (0: every one)")
      ->capture_default_str();
  app.add_option("--name", name, "device name announced in the hello")->capture_default_str();
  app.add_option("--max-force", max_force, "announced maximum force (N)")->capture_default_str();
  app.add_option("--max-stiffness", max_stiffness, "announced maximum stiffness (N/mm)")
      ->capture_default_str();
  app.add_option("--max-torque", max_torque, "announced maximum torque (N.mm)")->capture_default_str();
  app.add_flag("--quiet", quiet, "print only the summary");
  CLI11_PARSE(app, argc, argv);

  try {
    const Trajectory trajectory = load_trajectory_csv(file);
    TrajectoryCursor cursor(trajectory);
    const double length = trajectory.end() - trajectory.start();
    if (duration <= 0.0) duration = loop ? 1e300 : length;
    const int fd = connect_to(host, port);
    std::array<uint8_t, bridge::kMaxPacketSize> out{};
    std::array<uint8_t, 1024> in{};
    uint32_t sequence = 0;
    Summary summary;

    // Hello: the device's limits (the simulator never exceeds them) and its name. It is sent again
    // every kHelloRepeat until a wrench acknowledges it (flag bit 15), so the client may start
    // before the simulator: a hello sent to nobody is not lost.
    bridge::HelloPacket hello;
    hello.max_force = max_force;
    hello.max_stiffness = max_stiffness;
    hello.max_torque = max_torque;
    hello.workspace_min = Vec3::Constant(-200.0);
    hello.workspace_max = Vec3::Constant(200.0);
    std::copy_n(name.begin(), std::min(name.size(), hello.name.size()), hello.name.begin());
    bool acknowledged = false;
    int64_t next_hello = monotonic_ns();
    const auto send_hello = [&] {
      hello.sequence = sequence++;
      hello.client_time = static_cast<double>(monotonic_ns()) * 1e-9;
      if (::send(fd, out.data(), bridge::encode_hello(hello, out.data(), out.size()), 0) > 0)
        ++summary.hellos;
      next_hello = monotonic_ns() + kHelloRepeatNs;
    };

    // The client's servo loop: absolute deadlines at the given rate.
    const int64_t period = static_cast<int64_t>(std::llround(1e9 / rate));
    const int64_t start = monotonic_ns();
    int64_t deadline = start;
    double next_print = 0.0;
    Pose previous = trajectory.pose.front();
    for (uint64_t i = 0;; ++i) {
      sleep_until_ns(deadline);
      const double t = static_cast<double>(deadline - start) * 1e-9;
      if (t > duration) break;
      if (!acknowledged && monotonic_ns() >= next_hello) send_hello();

      // Read "the device": here the trajectory at time t.
      const double local = loop && length > 0.0 ? std::fmod(t, length) : std::min(t, length);
      bridge::PosePacket pose;
      pose.sequence = sequence++;
      pose.client_time = static_cast<double>(monotonic_ns()) * 1e-9;
      pose.pose = cursor.at(trajectory.start() + local);
      if (velocity && i > 0) {
        pose.has_velocity = true;
        pose.velocity = (pose.pose.p - previous.p) * rate;
        pose.angular_velocity = rotation_vector(pose.pose.q * previous.q.conjugate()) * rate;
      }
      previous = pose.pose;
      if (::send(fd, out.data(), bridge::encode_pose(pose, out.data(), out.size()), 0) > 0) ++summary.sent;

      // Take every wrench that arrived; the newest is what a device would render now.
      while (true) {
        const ssize_t n = ::recv(fd, in.data(), in.size(), MSG_DONTWAIT);
        if (n < 0) break;
        bridge::WrenchPacket w;
        if (bridge::parse_wrench(in.data(), static_cast<std::size_t>(n), w) != bridge::ParseResult::Wrench) {
          ++summary.bad;
          continue;
        }
        ++summary.received;
        if ((w.flags & bridge::kWrenchLimitsAcknowledged) != 0 && !acknowledged) {
          acknowledged = true;
          if (!quiet) std::printf("t=%8.3f hello acknowledged: the device's limits are in force\n", t);
        }
        summary.last_echo = w.sequence;
        summary.max_force = std::max(summary.max_force, w.force.norm());
        summary.rtt_sum += static_cast<double>(monotonic_ns()) * 1e-9 - w.client_time;
        if (!quiet && t >= next_print) {
          print_wrench(w, t);
          next_print = t + print_every;
        }
      }
      deadline += period;
    }
    ::close(fd);
    std::printf(
        "sent %llu poses and %llu hellos (%s), received %llu wrenches (%llu invalid), last echo %u, "
        "max |F| %.3f N, mean pose-to-wrench time %.3f ms\n",
        static_cast<unsigned long long>(summary.sent), static_cast<unsigned long long>(summary.hellos),
        acknowledged ? "acknowledged" : "never acknowledged: the scene's limits applied",
        static_cast<unsigned long long>(summary.received), static_cast<unsigned long long>(summary.bad),
        summary.last_echo, summary.max_force,
        summary.received ? summary.rtt_sum / static_cast<double>(summary.received) * 1e3 : 0.0);
    return summary.received > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
