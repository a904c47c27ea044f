// The Haply Inverse Service's protocol (haply_protocol.hpp): the address, `/version`, `/devices`,
// state messages and the force command, parsed and written with nlohmann-json.
#include "device/haply_protocol.hpp"

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>

#include "cariesim/common/error.hpp"

namespace cariesim::haply {

namespace {

using nlohmann::json;

// A port: digits in [1, 65535].
bool valid_port(std::string_view text) {
  unsigned port = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), port);
  return !text.empty() && ec == std::errc() && end == text.data() + text.size() && port >= 1 && port <= 65535;
}

// "SCHEME://HOST:PORT[/]" into host and port; throws naming the part that is wrong.
void split_url(std::string_view url, std::string_view scheme, std::string& host, std::string& port) {
  const std::string whole(url);
  const std::string prefix = std::string(scheme) + "://";
  if (url.substr(0, prefix.size()) != prefix)
    throw Error("haply URL '" + whole + "': expected " + prefix + "HOST:PORT");
  std::string_view rest = url.substr(prefix.size());
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  const std::size_t colon = rest.rfind(':');
  if (colon == std::string_view::npos || colon == 0)
    throw Error("haply URL '" + whole + "': expected " + prefix + "HOST:PORT (no port)");
  if (!valid_port(rest.substr(colon + 1)))
    throw Error("haply URL '" + whole + "': port '" + std::string(rest.substr(colon + 1)) +
                "' is not a number in [1, 65535]");
  host = std::string(rest.substr(0, colon));
  port = std::string(rest.substr(colon + 1));
}

// A "major.minor[.patch[.build]]" text's numbers; false when it does not start so.
bool parse_numbers(const std::string& text, ServiceVersion& v) {
  int* parts[3] = {&v.major, &v.minor, &v.patch};
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < 3; ++i) {
    const auto [next, ec] = std::from_chars(p, end, *parts[i]);
    if (ec != std::errc() || *parts[i] < 0) return i >= 2;  // the patch may be missing
    p = next;
    if (p == end || *p != '.') return i >= 1;
    ++p;
  }
  return true;
}

// A JSON vector {x, y, z} of finite numbers no larger than `limit`; "" or what is wrong with it.
std::string read_vec3(const json& parent, const char* field, double limit, Vec3& out) {
  const auto it = parent.find(field);
  if (it == parent.end() || !it->is_object()) return std::string(field) + " missing";
  for (int i = 0; i < 3; ++i) {
    const char* axis[3] = {"x", "y", "z"};
    const auto c = it->find(axis[i]);
    if (c == it->end() || !c->is_number())
      return std::string(field) + "." + axis[i] + (c == it->end() ? " missing" : " is not a number");
    const double value = c->get<double>();
    if (!std::isfinite(value) || std::abs(value) > limit)
      return std::string(field) + "." + axis[i] + " = " + c->dump() + " out of range";
    out[i] = value;
  }
  return "";
}

// A VerseGrip's state (orientation {w, x, y, z} and buttons {a, b, c}); "" or what is wrong.
std::string read_grip(const json& state, State& out) {
  const auto q = state.find("orientation");
  if (q == state.end() || !q->is_object()) return "orientation missing";
  double wxyz[4] = {0.0, 0.0, 0.0, 0.0};
  const char* names[4] = {"w", "x", "y", "z"};
  for (int i = 0; i < 4; ++i) {
    const auto c = q->find(names[i]);
    if (c == q->end() || !c->is_number())
      return std::string("orientation.") + names[i] + " missing or not a number";
    wxyz[i] = c->get<double>();
    if (!std::isfinite(wxyz[i])) return std::string("orientation.") + names[i] + " not finite";
  }
  Quat orientation(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  const double norm = orientation.norm();
  if (!(norm > 0.5 && norm < 1.5))
    return "orientation is not a unit quaternion (norm " + std::to_string(norm) + ")";
  out.orientation = orientation.normalized();
  out.buttons = 0;
  const auto b = state.find("buttons");
  if (b != state.end() && b->is_object()) {
    const char* keys[3] = {"a", "b", "c"};
    for (uint32_t i = 0; i < 3; ++i) {
      const auto k = b->find(keys[i]);
      if (k == b->end()) continue;
      if (!k->is_boolean() && !k->is_number()) return std::string("buttons.") + keys[i] + " is not a boolean";
      if (k->is_boolean() ? k->get<bool>() : k->get<double>() != 0.0) out.buttons |= 1u << i;
    }
  }
  out.grip = true;
  return "";
}

// The device ids of a JSON array of devices (each an object with a string device_id).
std::vector<std::string> ids_of(const json& doc, const char* key) {
  std::vector<std::string> out;
  const auto list = doc.find(key);
  if (list == doc.end()) return out;
  if (!list->is_array()) throw Error(std::string("haply inventory: '") + key + "' is not an array");
  for (std::size_t i = 0; i < list->size(); ++i) {
    const json& d = (*list)[i];
    const auto id = d.is_object() ? d.find("device_id") : d.end();
    if (!d.is_object() || id == d.end() || !id->is_string())
      throw Error(std::string("haply inventory: ") + key + "[" + std::to_string(i) + "].device_id missing");
    out.push_back(id->get<std::string>());
  }
  return out;
}

}  // namespace

std::string Endpoint::describe() const {
  return "http://" + http_host + ":" + http_port + ", ws://" + ws_host + ":" + ws_port;
}

// The defaults, one HTTP URL (WebSocket at the next port), or both URLs.
Endpoint parse_endpoint(std::string_view url) {
  Endpoint e;
  if (url.empty()) return e;
  const std::size_t comma = url.find(',');
  split_url(url.substr(0, comma), "http", e.http_host, e.http_port);
  if (comma == std::string_view::npos) {
    const unsigned next = static_cast<unsigned>(std::stoul(e.http_port)) + 1;
    if (next > 65535)
      throw Error("haply URL '" + std::string(url) + "': no port after " + e.http_port +
                  " for the WebSocket (name it: http://HOST:PORT,ws://HOST:PORT)");
    e.ws_host = e.http_host;
    e.ws_port = std::to_string(next);
  } else {
    split_url(url.substr(comma + 1), "ws", e.ws_host, e.ws_port);
  }
  return e;
}

// project_version (e.g. "3.2.1.0"), else git_tag.
ServiceVersion parse_version(std::string_view body) {
  const json doc = json::parse(body, nullptr, false);
  if (doc.is_discarded() || !doc.is_object())
    throw Error("haply /version: the answer is not a JSON object: '" + std::string(body.substr(0, 80)) + "'");
  ServiceVersion v;
  for (const char* field : {"project_version", "git_tag"}) {
    const auto it = doc.find(field);
    if (it == doc.end() || !it->is_string()) continue;
    v.text = it->get<std::string>();
    if (!parse_numbers(v.text, v))
      throw Error(std::string("haply /version: ") + field + " '" + v.text + "' is not MAJOR.MINOR.PATCH");
    return v;
  }
  throw Error("haply /version: neither project_version nor git_tag in the answer");
}

// The 3.1 JSON format: services 3.1 to 3.4.
void check_version(const ServiceVersion& v) {
  const std::string speaks = "cariesim speaks the 3.1 JSON format of Inverse Service 3." +
                             std::to_string(kOldestMinor) + " to 3." + std::to_string(kTooNewMinor - 1);
  if (v.major == 3 && v.minor >= kOldestMinor && v.minor < kTooNewMinor) return;
  if (v.major < 3 || (v.major == 3 && v.minor < kOldestMinor))
    throw Error("Haply Inverse Service " + v.text + " is too old: it speaks only the " +
                std::to_string(v.major) + "." + std::to_string(v.minor) + " JSON format; " + speaks +
                " (update the service)");
  throw Error("Haply Inverse Service " + v.text + " is newer than cariesim knows: its command schema " +
              "changed (set_cursor_force's field and the HTTP routes); " + speaks);
}

// `inverse3`, `verse_grip` and `wireless_verse_grip` arrays.
Inventory parse_inventory(std::string_view body) {
  const json doc = json::parse(body, nullptr, false);
  if (doc.is_discarded() || !doc.is_object())
    throw Error("haply inventory: not a JSON object: '" + std::string(body.substr(0, 80)) + "'");
  Inventory inv;
  inv.inverse3 = ids_of(doc, "inverse3");
  for (const char* key : {"wireless_verse_grip", "verse_grip"})
    for (std::string& id : ids_of(doc, key)) inv.grips.push_back(std::move(id));
  if (!inv.inverse3.empty()) {
    const json& first = doc["inverse3"][0];
    const auto config = first.find("config");
    if (config != first.end() && config->is_object()) {
      const auto h = config->find("handedness");
      if (h != config->end() && h->is_string()) inv.handedness = h->get<std::string>();
    }
  }
  return inv;
}

// The Inverse3 `device_id`'s cursor, and the first VerseGrip that carries a state.
std::optional<State> parse_state(std::string_view message, std::string_view device_id, std::string& error,
                                 bool& absent) {
  absent = false;
  const json doc = json::parse(message, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) {
    error = "state message is not a JSON object";
    return std::nullopt;
  }
  const auto list = doc.find("inverse3");
  const json* device = nullptr;
  if (list != doc.end() && list->is_array())
    for (const json& d : *list) {
      const auto id = d.is_object() ? d.find("device_id") : d.end();
      if (id != d.end() && id->is_string() && id->get<std::string>() == device_id) device = &d;
    }
  if (device == nullptr) {
    absent = true;
    error = "Inverse3 " + std::string(device_id) + " absent from the state message";
    return std::nullopt;
  }
  const auto state = device->find("state");
  if (state == device->end() || !state->is_object()) {
    error = "inverse3 " + std::string(device_id) + ": state missing";
    return std::nullopt;
  }
  State out;
  error = read_vec3(*state, "cursor_position", kMaxCoordinate, out.position);
  if (error.empty()) error = read_vec3(*state, "cursor_velocity", kMaxSpeed, out.velocity);
  if (!error.empty()) {
    error = "inverse3 " + std::string(device_id) + ": " + error;
    return std::nullopt;
  }
  for (const char* key : {"wireless_verse_grip", "verse_grip"}) {
    const auto grips = doc.find(key);
    if (grips == doc.end() || !grips->is_array() || grips->empty()) continue;
    const json& g = (*grips)[0];
    const auto gs = g.is_object() ? g.find("state") : g.end();
    if (gs == g.end() || !gs->is_object()) continue;
    error = read_grip(*gs, out);
    if (!error.empty()) {
      error = std::string(key) + "[0]: " + error;
      return std::nullopt;
    }
    break;
  }
  return out;
}

// {"inverse3":[{"device_id":ID,"commands":{"set_cursor_force":{"values":{x,y,z}}}}]}
std::string force_command(std::string_view device_id, const Vec3& force) {
  json values = {{"x", force.x()}, {"y", force.y()}, {"z", force.z()}};
  json device = {{"device_id", std::string(device_id)},
                 {"commands", {{"set_cursor_force", {{"values", std::move(values)}}}}}};
  json doc = {{"inverse3", json::array({std::move(device)})}};
  return doc.dump();
}

}  // namespace cariesim::haply
