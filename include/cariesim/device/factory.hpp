#pragma once
/// Devices from a spec string (the `--device` option of `cariesim run` and `cariesim servo`): `null`,
/// `scripted:FILE[:loop]`, `replay:FILE[:loop]` (a session recording, through make_replay_device of
/// record/recorder.hpp; cariesim_runtime links cariesim_record for it), `udp:PORT[:HOST]`. `mouse`
/// lives in the viewer, which composes it.

#include <memory>
#include <string>

#include "cariesim/device/device.hpp"

namespace cariesim {

/// What a device needs to know about the scene it drives.
struct DeviceOptions {
  Pose home;            ///< where `null` holds the tool and `udp` reports it before a client (tool_home)
  DeviceLimits limits;  ///< the simulator's device limits (Model::limits)
  double udp_timeout = 0.05;  ///< s, the UDP bridge's largest accepted transit delay
  bool realtime = true;       ///< the UDP bridge's threads ask for SCHED_FIFO (UdpOptions::realtime_priority)
};

/// Makes a device from a spec. Throws cariesim::Error naming the spec when it is unknown or bad
/// (missing file name, port out of range, unreadable trajectory or recording).
std::unique_ptr<Device> make_device(const std::string& spec, const DeviceOptions& options = {});

}  // namespace cariesim
