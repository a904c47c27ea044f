#pragma once
/// Devices from a spec string (the `--device` option of `cariesim run` and `cariesim servo`): `null`,
/// `scripted:FILE[:loop]` (a trajectory CSV, scene/trajectory.hpp), `replay:FILE[:loop]` (a session
/// recording, record/replay.hpp), `udp:PORT[:HOST]`. The factory lives in the runtime because it
/// reaches up to scene and record; the device module below it knows none of them. `mouse` lives in
/// the viewer, which composes it and hands it to a Session (servo/session.hpp).

#include <memory>
#include <string>

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
};

/// Makes a device from a spec. Throws cariesim::Error naming the spec when it is unknown or bad
/// (missing file name, port out of range, unreadable trajectory or recording).
std::unique_ptr<Device> make_device(const std::string& spec, const DeviceOptions& options = {});

}  // namespace cariesim
