#pragma once
/// Devices from a spec string (the `--device` option of `cariesim run`, `cariesim servo` and
/// `cariesim study run`), one backend per spec prefix: `PREFIX` or `PREFIX:ARGUMENT`. Built in:
/// `null`, `scripted:FILE[:loop]` (a trajectory CSV, device/trajectory_csv.hpp) and `udp:PORT[:HOST]`
/// (device/udp_device.hpp). A module above registers its own: the record module's
/// `replay:FILE[:loop]` (a ReplayDevice, device/replay.hpp, over a recording's source;
/// register_replay_device, record/replay.hpp, which the runtime's Session and the apps call), as the
/// hardware backends will. `mouse` lives in the viewer, which composes it and hands
/// it to a Session (servo/session.hpp).
///
///   register_device_backend({"mydevice", "mydevice:ID", [](const std::string& spec,
///       std::optional<std::string_view> argument, const DeviceOptions& options) { ... }});
///   auto device = make_device("mydevice:3", options);

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/device/device.hpp"
#include "cariesim/device/input_guard.hpp"
#include "cariesim/device/limits.hpp"

namespace cariesim {

/// What a device needs to know about the scene it drives.
struct DeviceOptions {
  Pose home;            ///< where `null` holds the tool and `udp` reports it before a client (tool_home)
  DeviceLimits limits;  ///< the simulator's device limits (Model::defaults.limits), which info() reports
  /// How readings are judged (Model::settings.input, device/input_guard.hpp): the UDP bridge's largest
  /// accepted transit delay is `input.stale_after`, the age at which the step calls a reading stale.
  InputLimits input;
  bool realtime = true;  ///< the UDP bridge's threads ask for SCHED_FIFO (UdpOptions::realtime_priority)
  /// A hardware device's profile file (device/profile.hpp, `--device-profile`); none: the backend's
  /// built-in default.
  std::optional<std::filesystem::path> profile;
};

/// Makes a device of one backend from the whole `spec` and its `argument` (the text after the first
/// ':', none when the spec has no ':'); throws cariesim::Error (bad_device_spec) when it cannot.
using DeviceMaker = std::function<std::unique_ptr<Device>(
    const std::string& spec, std::optional<std::string_view> argument, const DeviceOptions& options)>;

/// One backend of the factory.
struct DeviceBackend {
  std::string prefix;  ///< the spec's text before the first ':' (e.g. "replay")
  std::string usage;   ///< how its spec is written, for messages (e.g. "replay:FILE[:loop]")
  DeviceMaker make;
};

/// Adds a backend, or replaces the one with the same prefix (so registering twice is harmless).
/// Thread-safe; call it at start, before devices are made.
void register_device_backend(DeviceBackend backend);

/// The usages of the registered backends, in registration order (the built-in ones first).
[[nodiscard]] std::vector<std::string> device_spec_usages();

/// Makes a device from a spec. Throws cariesim::Error naming the spec when it is unknown or bad
/// (missing file name, port out of range, unreadable trajectory or recording).
std::unique_ptr<Device> make_device(const std::string& spec, const DeviceOptions& options = {});

/// Throws cariesim::Error "device spec 'SPEC': WHY".
[[noreturn]] void bad_device_spec(const std::string& spec, const std::string& why);

/// Removes a trailing ":loop" option from a file argument (the file may itself contain ':'); true
/// when there was one.
bool strip_loop_option(std::string_view& argument);

}  // namespace cariesim
