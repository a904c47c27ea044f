#pragma once
/// The hardware backends of the device factory (docs/devices.md): each vendor SDK's device and its
/// survey for `cariesim device list`. The factory registers `touch[:NAME]`, `fd[:INDEX|SERIAL]` and
/// `haply[:URL]`, each a HapticDevice (device/haptic_device.hpp) over one of these.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/device/hardware.hpp"
#include "cariesim/device/shared_library.hpp"

namespace cariesim {

/// What `cariesim device list` says about one backend.
struct HardwareSurvey {
  std::string backend;               ///< "touch", "fd", "haply"
  LibraryProbe sdk;                  ///< where the SDK was looked for and what was found
  std::string version;               ///< the SDK's (or service's) version, when found
  std::vector<HardwareInfo> devices; ///< the devices attached (info() of each, opened and closed)
  std::string problem;               ///< why nothing could be listed (e.g. "SDK 3.0 older than 3.4")
  std::string install;               ///< what to install when the SDK is missing
};

/// OpenHaptics HD (libHD.so; CARIESIM_HD_LIBRARY overrides): the device configured under `name`
/// (empty: the default device, and the default when the name fails). Loads the SDK; opens nothing.
std::unique_ptr<HardwareDevice> make_touch_device(std::string_view name);
HardwareSurvey survey_touch();

/// Force Dimension DHD/DRD (libdrd.so.3, else libdhd.so.3; CARIESIM_FD_LIBRARY overrides): the
/// device at `index_or_serial` (empty: the first).
std::unique_ptr<HardwareDevice> make_fd_device(std::string_view index_or_serial);
HardwareSurvey survey_fd();

/// Haply Inverse3 through the Inverse Service at `url` (empty: http://localhost:10000 and the
/// WebSocket on ws://localhost:10001).
std::unique_ptr<HardwareDevice> make_haply_device(std::string_view url);
HardwareSurvey survey_haply();

}  // namespace cariesim
