// The device factory (servo/device_factory.hpp): spec strings to devices of the device module, the
// record module's replay device and scene trajectory files.
#include "cariesim/servo/device_factory.hpp"

#include <charconv>
#include <string_view>

#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "cariesim/device/udp_device.hpp"
#include "cariesim/record/replay.hpp"
#include "cariesim/scene/trajectory.hpp"

namespace cariesim {

namespace {

[[noreturn]] void bad_spec(const std::string& spec, const std::string& why) {
  throw Error("device spec '" + spec + "': " + why);
}

// Removes a trailing ":loop" option from a file argument (the file may itself contain ':').
bool strip_loop(std::string_view& rest) {
  constexpr std::string_view kLoop = ":loop";
  if (rest.size() <= kLoop.size() || rest.substr(rest.size() - kLoop.size()) != kLoop) return false;
  rest.remove_suffix(kLoop.size());
  return true;
}

// `scripted:FILE[:loop]`.
std::unique_ptr<Device> make_scripted(const std::string& spec, std::string_view rest,
                                      const DeviceOptions& options) {
  const bool loop = strip_loop(rest);
  if (rest.empty()) bad_spec(spec, "missing trajectory file (expected scripted:FILE[:loop])");
  const std::string file(rest);
  try {
    return std::make_unique<ScriptedDevice>(load_trajectory_csv(file), loop, file, options.limits);
  } catch (const Error& e) {
    bad_spec(spec, e.what());
  }
}

// `replay:FILE[:loop]`: the record module's replay device.
std::unique_ptr<Device> make_replay(const std::string& spec, std::string_view rest) {
  const bool loop = strip_loop(rest);
  if (rest.empty()) bad_spec(spec, "missing recording file (expected replay:FILE[:loop])");
  try {
    return make_replay_device(std::string(rest), loop);
  } catch (const Error& e) {
    bad_spec(spec, e.what());
  }
}

// `udp:PORT[:HOST]`.
std::unique_ptr<Device> make_udp(const std::string& spec, std::string_view rest,
                                 const DeviceOptions& options) {
  const std::size_t colon = rest.find(':');
  const std::string_view port_text = rest.substr(0, colon);
  unsigned port = 0;
  const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port_text.empty() || ec != std::errc() || end != port_text.data() + port_text.size() || port > 65535)
    bad_spec(spec, "port '" + std::string(port_text) +
                       "' is not a number in [0, 65535] (expected udp:PORT[:HOST])");
  UdpOptions udp;
  udp.port = static_cast<uint16_t>(port);
  if (colon != std::string_view::npos) {
    udp.host = std::string(rest.substr(colon + 1));
    if (udp.host.empty()) bad_spec(spec, "empty host (expected udp:PORT[:HOST])");
  }
  udp.timeout = options.input.stale_after;
  udp.limits = options.limits;
  udp.home = options.home;
  if (!options.realtime) udp.realtime_priority = 0;
  return std::make_unique<UdpDevice>(udp);
}

}  // namespace

std::unique_ptr<Device> make_device(const std::string& spec, const DeviceOptions& options) {
  const std::string_view s(spec);
  const std::size_t colon = s.find(':');
  const std::string_view kind = s.substr(0, colon);
  const std::string_view rest = colon == std::string_view::npos ? std::string_view{} : s.substr(colon + 1);
  if (kind == "null") {
    if (colon != std::string_view::npos) bad_spec(spec, "null takes no argument");
    return std::make_unique<NullDevice>(options.home, options.limits);
  }
  if (kind == "scripted") return make_scripted(spec, rest, options);
  if (kind == "udp") return make_udp(spec, rest, options);
  if (kind == "replay") return make_replay(spec, rest);
  if (kind == "mouse") bad_spec(spec, "the mouse device lives in the viewer, which composes it");
  bad_spec(
      spec,
      "unknown device (expected null, scripted:FILE[:loop], replay:FILE[:loop], udp:PORT[:HOST] or mouse)");
}

}  // namespace cariesim
