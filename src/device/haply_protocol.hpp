#pragma once
// The Haply Inverse Service's protocol as cariesim speaks it (docs/devices.md, "Haply Inverse3"): the
// service's address, its `/version` and `/devices` answers over HTTP, the state messages and the force
// command of its WebSocket (the JSON format of services 3.1 to 3.4). Pure functions over text, so the
// tests feed them hostile messages; the backend (haply.cpp) calls them on its I/O thread, never on the
// servo thread (they allocate).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim::haply {

/// Where the service listens: HTTP (`/version`, `/devices`) and the WebSocket of the simulation channel.
struct Endpoint {
  std::string http_host = "localhost";
  std::string http_port = "10000";
  std::string ws_host = "localhost";
  std::string ws_port = "10001";
  /// "http://localhost:10000, ws://localhost:10001", for messages.
  [[nodiscard]] std::string describe() const;
};

/// The endpoint of a `haply[:URL]` argument: empty gives the service's defaults; `http://HOST:PORT`
/// puts the WebSocket on HOST at PORT + 1 (the service's own layout); `http://HOST:PORT,ws://HOST:PORT`
/// names both. Throws cariesim::Error naming what is wrong.
Endpoint parse_endpoint(std::string_view url);

/// The service's version as `/version` tells it (project_version, else git_tag).
struct ServiceVersion {
  int major = 0, minor = 0, patch = 0;
  std::string text;  ///< as the service wrote it, e.g. "3.2.1.0"
};

/// The oldest and the first too-new version whose WebSocket takes
/// `set_cursor_force: {values: {x, y, z}}` (the 3.1 JSON format): 3.0 speaks only the 3.0 format;
/// 3.5 renamed the command's field and moved its HTTP routes.
inline constexpr int kOldestMinor = 1;
inline constexpr int kTooNewMinor = 5;

/// Parses a `/version` body; throws cariesim::Error naming the missing or malformed field.
ServiceVersion parse_version(std::string_view body);
/// Throws cariesim::Error naming the version when its command schema is not the one cariesim speaks.
void check_version(const ServiceVersion& version);

/// What `/devices` (or a WebSocket's first message) lists.
struct Inventory {
  std::vector<std::string> inverse3;  ///< device ids of the Inverse3s
  std::vector<std::string> grips;     ///< device ids of the VerseGrips (wired or wireless)
  std::string handedness;             ///< the first Inverse3's config.handedness, when given
};
/// Parses a `/devices` body or a WebSocket inventory; throws cariesim::Error naming the bad field.
Inventory parse_inventory(std::string_view body);

/// One state of the device `device_id` and the first VerseGrip, in the service's units (m, m/s).
struct State {
  Vec3 position = Vec3::Zero();         ///< m, cursor_position
  Vec3 velocity = Vec3::Zero();         ///< m/s, cursor_velocity
  bool grip = false;                    ///< a VerseGrip's state was in the message
  Quat orientation = Quat::Identity();  ///< the grip's orientation (unit)
  uint32_t buttons = 0;                 ///< bit 0: button a, 1: b, 2: c
};

/// The largest coordinate (m) a state may carry: an Inverse3's reach is well inside it, so anything
/// beyond is a corrupt message.
inline constexpr double kMaxCoordinate = 2.0;
/// The largest speed (m/s) a state may carry.
inline constexpr double kMaxSpeed = 50.0;

/// Parses one state message. Returns nullopt with `error` saying what was wrong (bad JSON, a missing or
/// non-numeric field, a value out of range) or "device <id> absent" when the message lists no such
/// Inverse3 (`absent` set).
std::optional<State> parse_state(std::string_view message, std::string_view device_id, std::string& error,
                                 bool& absent);

/// The command that sets the cursor force (N, the device's frame) of `device_id`.
std::string force_command(std::string_view device_id, const Vec3& force);

}  // namespace cariesim::haply
