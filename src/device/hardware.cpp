#include "cariesim/device/hardware.hpp"

#include <array>
#include <utility>

namespace cariesim {

std::string describe_hardware_faults(uint32_t faults) {
  static constexpr std::array<std::pair<uint32_t, const char*>, 7> kNames = {{
      {kHardwareCommunication, "communication error"},
      {kHardwareOverheat, "motors too warm"},
      {kHardwareForceExceeded, "force above the device's limit"},
      {kHardwareVelocityExceeded, "stylus too fast"},
      {kHardwareNotCalibrated, "not calibrated"},
      {kHardwareLost, "device lost"},
      {kHardwareOther, "device error"},
  }};
  std::string out;
  for (const auto& [bit, name] : kNames) {
    if ((faults & bit) == 0) continue;
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

}  // namespace cariesim
