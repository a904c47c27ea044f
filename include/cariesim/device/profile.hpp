#pragma once
/// A device profile (docs/devices.md "The profile"): how a hardware device's hand space maps onto the
/// scene. A strict YAML file (unknown keys, wrong types and out-of-range values are refused with
/// file:line:column and the field) or the built-in default of each backend:
///
///   rotation: {axis: [0, 0, 1], angle: 0}  # operator frame -> scene (x right, y away, z up)
///   translation: [0, 0, 12.5]              # mm: the scene point the workspace centre maps to
///   scale: 0.5                             # mm of scene per mm of hand
///   stylus_offset: [0, 0, -20]             # mm: the explorer's tip from the device point (tool frame)
///   fixed_orientation: {axis: [0, 1, 0], angle: -25}  # the tool's orientation on a 3-DoF-input device
///   buttons: {0: clutch, 1: mark_mild}     # button index: clutch, mark_mild, mark_severe, end_case
///   force_enable_below: 0.5                # N: force is enabled once the commanded force is below this
///   ramp_time: 0.5                         # s: force ramps in over this after enabling and after a clutch
///   continuous_time_constant: 10           # s: the thermal model's time constant
///
/// Any key left out takes the default: the centre of the device's workspace at the scene's tool home,
/// the stylus's rest orientation at the tool home's orientation, scale 1, no offset.

#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include "cariesim/common/math.hpp"
#include "cariesim/device/device.hpp"

namespace cariesim {

/// Most buttons a profile maps.
inline constexpr int kMaxProfileButtons = 16;

struct DeviceProfile {
  std::string origin = "default";  ///< the file it came from, or "default"
  Quat rotation = Quat::Identity();  ///< operator frame -> scene
  std::optional<Vec3> translation;   ///< mm, scene point of the workspace centre; none: the tool home
  double scale = 1.0;                ///< mm of scene per mm of hand, in (0, 10]
  Vec3 stylus_offset = Vec3::Zero(); ///< mm, the tip from the device point, in the tool frame
  /// The tool's orientation when the device senses none (dof_in 3); none: the tool home's.
  std::optional<Quat> fixed_orientation;
  /// What each button does (DeviceAction bits, 0 = nothing); the default: button 0 clutch, button 1
  /// mark mild, button 2 mark severe, button 3 end case (buttons a device lacks do nothing).
  std::array<uint32_t, kMaxProfileButtons> buttons{kActionClutch, kActionMarkMild, kActionMarkSevere,
                                                   kActionEndCase};
  double force_enable_below = 0.5;        ///< N
  double ramp_time = 0.5;                 ///< s
  double continuous_time_constant = 10.0; ///< s
};

/// Reads a profile file; throws cariesim::Error "file:line:column: field: message".
DeviceProfile load_device_profile(const std::filesystem::path& file);
/// Parses a profile's text (`origin` names it in messages).
DeviceProfile parse_device_profile(const std::string& text, const std::string& origin);
/// The actions of a set of pressed buttons (bit i = button i).
uint32_t profile_actions(const DeviceProfile& profile, uint32_t buttons);

}  // namespace cariesim
