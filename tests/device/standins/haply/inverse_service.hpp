#pragma once
// A stand-in for Haply's Inverse Service (test code, never installed): HTTP `/version` and `/devices`
// and the WebSocket simulation channel on loopback ports of its own, speaking the 3.1 JSON format over
// a simulated Inverse3 cursor (a mass with damping, pushed by a test's "hand" and by the commanded
// force) and a VerseGrip (orientation, buttons a, b, c). One state answers each command, paced by the
// simulated device's rate. Switches: another version, no device, no VerseGrip, connections dropped,
// the service gone and back, slow answers.

#include <cstdint>
#include <memory>
#include <string>

#include "cariesim/common/math.hpp"

namespace cariesim::test {

/// How the stand-in starts.
struct InverseServiceOptions {
  std::string version = "3.2.1.0";  ///< `/version`'s project_version
  std::string device_id = "049D";
  std::string grip_id = "A1B2";
  bool inverse3 = true;          ///< an Inverse3 is attached
  bool grip = true;              ///< a wireless VerseGrip is attached
  double rate_hz = 1000.0;       ///< Hz, the simulated device's rate: one answer per tick at most
  double mass = 0.2;             ///< kg, the cursor's (and hand's) moving mass
  double damping = 3.0;          ///< N·s/m, viscous damping of the cursor
  unsigned short http_port = 0;  ///< 0: any free port
  unsigned short ws_port = 0;    ///< 0: any free port
};

class InverseService {
 public:
  /// Listens on 127.0.0.1 (HTTP and WebSocket, at the options' ports or free ones) and serves on a
  /// thread of its own.
  explicit InverseService(InverseServiceOptions options = {});
  ~InverseService();
  InverseService(const InverseService&) = delete;
  InverseService& operator=(const InverseService&) = delete;

  /// The `haply:` argument that reaches it: "http://127.0.0.1:P,ws://127.0.0.1:Q".
  [[nodiscard]] std::string url() const;

  // Switches.
  void set_version(const std::string& version);
  void set_inverse3(bool attached);       ///< the Inverse3 listed (inventory, states) or not
  void set_answer_delay(double seconds);  ///< s added before each answer (a slow service)
  void drop_connections();                ///< closes every WebSocket now (the service keeps listening)
  void go_away();                         ///< stops listening and closes everything (the service stopped)
  void come_back();                       ///< listens again on the same ports

  // The simulated hand and device.
  void push_hand(const Vec3& force);        ///< N, the hand's force on the cursor (device frame), held
  void place_cursor(const Vec3& position);  ///< m, puts the cursor there at rest
  void set_orientation(const Quat& q);      ///< the VerseGrip's orientation
  void set_buttons(uint32_t bits);          ///< bit 0: a, 1: b, 2: c

  // Read back.
  [[nodiscard]] Vec3 last_force() const;          ///< N, the newest set_cursor_force's values
  [[nodiscard]] Vec3 peak_force() const;          ///< N, the largest set_cursor_force so far
  [[nodiscard]] Vec3 last_nonzero_force() const;  ///< N, the newest set_cursor_force that was not zero
  [[nodiscard]] Vec3 position() const;            ///< m, the cursor
  [[nodiscard]] uint64_t commands() const;        ///< set_cursor_force commands received
  [[nodiscard]] uint64_t bad_commands() const;    ///< messages that were not a command of this device
  [[nodiscard]] uint64_t connections() const;     ///< WebSocket sessions accepted so far
  [[nodiscard]] int open_connections() const;     ///< WebSocket sessions open now

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cariesim::test
