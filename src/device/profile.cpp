#include "cariesim/device/profile.hpp"

#include <cmath>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/yaml.hpp"

namespace cariesim {

namespace {

// Largest profile file accepted (a profile is a few lines).
constexpr std::uintmax_t kMaxProfileBytes = 64 * 1024;

// The button map: {index: action}.
void buttons(const io::Reader& reader, const YAML::Node& node, const std::string& path,
             std::array<uint32_t, kMaxProfileButtons>& out) {
  if (!node.IsMap()) reader.fail(node, path, "must be a mapping of button index to action");
  out.fill(0);
  for (const auto& entry : node) {
    const int64_t index = reader.integer_in(entry.first, path, 0, kMaxProfileButtons - 1);
    const std::string sub = path + "." + std::to_string(index);
    const std::size_t action = reader.choice(entry.second, sub, "button action",
                                             {"none", "clutch", "mark_mild", "mark_severe", "end_case"});
    static constexpr std::array<uint32_t, 5> kActions = {0, kActionClutch, kActionMarkMild, kActionMarkSevere,
                                                         kActionEndCase};
    out[static_cast<std::size_t>(index)] = kActions[action];
  }
}

}  // namespace

DeviceProfile parse_device_profile(const std::string& text, const std::string& origin) {
  const YAML::Node root = io::parse_document(text, origin, kMaxProfileBytes);
  const io::Reader reader(origin);
  DeviceProfile profile;
  profile.origin = origin;
  if (!root || root.IsNull()) return profile;
  const io::Fields fields(reader, root, "",
                          {"rotation", "translation", "scale", "stylus_offset", "fixed_orientation",
                           "buttons", "force_enable_below", "ramp_time", "continuous_time_constant"});
  if (fields.has("rotation"))
    profile.rotation = reader.rotation(fields.get("rotation"), fields.sub("rotation"));
  if (fields.has("translation"))
    profile.translation = reader.vec3(fields.get("translation"), fields.sub("translation"));
  fields.positive("scale", profile.scale, 10.0, "mm of scene per mm of hand");
  if (fields.has("stylus_offset")) {
    profile.stylus_offset = reader.vec3(fields.get("stylus_offset"), fields.sub("stylus_offset"));
    if (profile.stylus_offset.norm() > 500.0)
      reader.fail(fields.get("stylus_offset"), fields.sub("stylus_offset"), "must be within 500 mm");
  }
  if (fields.has("fixed_orientation"))
    profile.fixed_orientation =
        reader.rotation(fields.get("fixed_orientation"), fields.sub("fixed_orientation"));
  if (fields.has("buttons")) buttons(reader, fields.get("buttons"), fields.sub("buttons"), profile.buttons);
  fields.number_in("force_enable_below", profile.force_enable_below, 0.01, 5.0, "N");
  fields.number_in("ramp_time", profile.ramp_time, 0.0, 10.0, "s");
  fields.number_in("continuous_time_constant", profile.continuous_time_constant, 0.1, 600.0, "s");
  return profile;
}

DeviceProfile load_device_profile(const std::filesystem::path& file) {
  return parse_device_profile(io::read_file(file, "device profile", kMaxProfileBytes), file.string());
}

uint32_t profile_actions(const DeviceProfile& profile, uint32_t buttons) {
  uint32_t actions = 0;
  for (int i = 0; i < kMaxProfileButtons; ++i)
    if ((buttons & (1u << i)) != 0) actions |= profile.buttons[static_cast<std::size_t>(i)];
  return actions;
}

}  // namespace cariesim
