// The device factory (device/factory.hpp): a registry of backends by spec prefix, with the null,
// scripted, UDP and Force Dimension (fd, docs/devices.md) backends built in.
#include "cariesim/device/factory.hpp"

#include <charconv>
#include <mutex>
#include <utility>

#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "cariesim/device/profile.hpp"
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/device/udp_device.hpp"

namespace cariesim {

namespace {

// `null`: holds the tool at the scene's home.
std::unique_ptr<Device> make_null(const std::string& spec, std::optional<std::string_view> argument,
                                  const DeviceOptions& options) {
  if (argument) bad_device_spec(spec, "null takes no argument");
  return std::make_unique<NullDevice>(options.home, options.limits);
}

// `scripted:FILE[:loop]`.
std::unique_ptr<Device> make_scripted(const std::string& spec, std::optional<std::string_view> argument,
                                      const DeviceOptions& options) {
  std::string_view rest = argument.value_or(std::string_view{});
  const bool loop = strip_loop_option(rest);
  if (rest.empty()) bad_device_spec(spec, "missing trajectory file (expected scripted:FILE[:loop])");
  const std::string file(rest);
  try {
    return std::make_unique<ScriptedDevice>(load_trajectory_csv(file), loop, file, options.limits);
  } catch (const Error& e) {
    bad_device_spec(spec, e.what());
  }
}

// `udp:PORT[:HOST]`.
std::unique_ptr<Device> make_udp(const std::string& spec, std::optional<std::string_view> argument,
                                 const DeviceOptions& options) {
  const std::string_view rest = argument.value_or(std::string_view{});
  const std::size_t colon = rest.find(':');
  const std::string_view port_text = rest.substr(0, colon);
  unsigned port = 0;
  const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port_text.empty() || ec != std::errc() || end != port_text.data() + port_text.size() || port > 65535)
    bad_device_spec(spec, "port '" + std::string(port_text) +
                              "' is not a number in [0, 65535] (expected udp:PORT[:HOST])");
  UdpOptions udp;
  udp.port = static_cast<uint16_t>(port);
  if (colon != std::string_view::npos) {
    udp.host = std::string(rest.substr(colon + 1));
    if (udp.host.empty()) bad_device_spec(spec, "empty host (expected udp:PORT[:HOST])");
  }
  udp.timeout = options.input.stale_after;
  udp.limits = options.limits;
  udp.home = options.home;
  if (!options.realtime) udp.realtime_priority = 0;
  return std::make_unique<UdpDevice>(udp);
}

// A hardware device (docs/devices.md): the backend's device behind the profile (the file given, or
// the built-in default), as a HapticDevice; what fails (the SDK, the device, the profile) names the
// spec.
template <class MakeHardware>
std::unique_ptr<Device> make_hardware(const std::string& spec, const DeviceOptions& options,
                                      MakeHardware make_hardware_device) {
  try {
    return std::make_unique<HapticDevice>(
        make_hardware_device(), options.profile ? load_device_profile(*options.profile) : DeviceProfile{},
        options.home);
  } catch (const Error& e) {
    bad_device_spec(spec, e.what());
  }
}

// `touch[:NAME]`: OpenHaptics HD's device configured under NAME (none: the default device).
std::unique_ptr<Device> make_touch(const std::string& spec, std::optional<std::string_view> argument,
                                   const DeviceOptions& options) {
  if (argument && argument->empty()) bad_device_spec(spec, "empty device name (expected touch[:NAME])");
  return make_hardware(spec, options,
                       [&] { return make_touch_device(argument.value_or(std::string_view{})); });
}

// `fd[:INDEX|SERIAL]`: a Force Dimension device (or a Falcon).
std::unique_ptr<Device> make_fd(const std::string& spec, std::optional<std::string_view> argument,
                                const DeviceOptions& options) {
  return make_hardware(spec, options, [&] { return make_fd_device(argument.value_or(std::string_view{})); });
}

// `haply[:URL]`: an Inverse3 through Haply's Inverse Service.
std::unique_ptr<Device> make_haply(const std::string& spec, std::optional<std::string_view> argument,
                                   const DeviceOptions& options) {
  return make_hardware(spec, options,
                       [&] { return make_haply_device(argument.value_or(std::string_view{})); });
}

// The registry: the built-in backends first; guarded, since a module may register from any thread.
struct Registry {
  std::mutex mutex;
  std::vector<DeviceBackend> backends{
      {"null", "null", make_null},          {"scripted", "scripted:FILE[:loop]", make_scripted},
      {"udp", "udp:PORT[:HOST]", make_udp}, {"touch", "touch[:NAME]", make_touch},
      {"fd", "fd[:INDEX|SERIAL]", make_fd}, {"haply", "haply[:URL]", make_haply}};
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

void bad_device_spec(const std::string& spec, const std::string& why) {
  throw Error("device spec '" + spec + "': " + why);
}

bool strip_loop_option(std::string_view& argument) {
  constexpr std::string_view kLoop = ":loop";
  if (argument.size() <= kLoop.size() || argument.substr(argument.size() - kLoop.size()) != kLoop)
    return false;
  argument.remove_suffix(kLoop.size());
  return true;
}

void register_device_backend(DeviceBackend backend) {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  for (DeviceBackend& existing : r.backends)
    if (existing.prefix == backend.prefix) {
      existing = std::move(backend);
      return;
    }
  r.backends.push_back(std::move(backend));
}

std::vector<std::string> device_spec_usages() {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> out;
  for (const DeviceBackend& b : r.backends) out.push_back(b.usage);
  return out;
}

// The backend of the spec's prefix (copied out of the lock), else an error listing the known ones.
std::unique_ptr<Device> make_device(const std::string& spec, const DeviceOptions& options) {
  const std::string_view s(spec);
  const std::size_t colon = s.find(':');
  const std::string_view prefix = s.substr(0, colon);
  std::optional<std::string_view> argument;
  if (colon != std::string_view::npos) argument = s.substr(colon + 1);
  DeviceMaker make;
  {
    Registry& r = registry();
    const std::lock_guard<std::mutex> lock(r.mutex);
    for (const DeviceBackend& b : r.backends)
      if (b.prefix == prefix) make = b.make;
  }
  if (make) return make(spec, argument, options);
  if (prefix == "mouse") bad_device_spec(spec, "the mouse device lives in the viewer, which composes it");
  std::string known;
  for (const std::string& usage : device_spec_usages()) known += usage + ", ";
  bad_device_spec(spec, "unknown device (expected " + known + "or mouse)");
}

}  // namespace cariesim
