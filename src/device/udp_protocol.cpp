#include "cariesim/device/udp_protocol.hpp"

#include <bit>
#include <cmath>
#include <cstring>

#include "cariesim/device/input_guard.hpp"

namespace cariesim::bridge {

namespace {

// Byte offsets shared by every packet (docs/device-bridge.md, "Header").
constexpr std::size_t kOffMagic = 0, kOffVersion = 4, kOffType = 5, kOffFlags = 6, kOffSequence = 8;

// Little-endian field access, independent of the host's byte order.
uint16_t get_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t get_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
uint64_t get_u64(const uint8_t* p) {
  return static_cast<uint64_t>(get_u32(p)) | (static_cast<uint64_t>(get_u32(p + 4)) << 32);
}
double get_f64(const uint8_t* p) { return std::bit_cast<double>(get_u64(p)); }
Vec3 get_vec3(const uint8_t* p) { return Vec3(get_f64(p), get_f64(p + 8), get_f64(p + 16)); }

void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void put_u64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void put_f64(uint8_t* p, double v) { put_u64(p, std::bit_cast<uint64_t>(v)); }
void put_vec3(uint8_t* p, const Vec3& v) {
  put_f64(p, v.x());
  put_f64(p + 8, v.y());
  put_f64(p + 16, v.z());
}

void put_header(uint8_t* p, PacketType type, uint16_t flags, uint32_t sequence) {
  put_u32(p + kOffMagic, kMagic);
  p[kOffVersion] = kVersion;
  p[kOffType] = static_cast<uint8_t>(type);
  put_u16(p + kOffFlags, flags);
  put_u32(p + kOffSequence, sequence);
}

// Checks the common header: magic, length, version. Returns Pose when it is fine (the caller then
// looks at the type), else the reason.
ParseResult check_header(const uint8_t* data, std::size_t size) {
  if (size < 4) return ParseResult::Truncated;
  if (get_u32(data + kOffMagic) != kMagic) return ParseResult::BadMagic;
  if (size < kHeaderSize) return ParseResult::Truncated;
  if (data[kOffVersion] != kVersion) return ParseResult::BadVersion;
  return ParseResult::Pose;
}

// Checks a datagram's exact length for its type.
ParseResult check_size(std::size_t size, std::size_t expected) {
  if (size < expected) return ParseResult::Truncated;
  if (size > expected) return ParseResult::Malformed;
  return ParseResult::Pose;
}

bool all_zero(const uint8_t* p, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    if (p[i] != 0) return false;
  return true;
}

// Pose packet body (docs/device-bridge.md, "Pose").
ParseResult parse_pose_body(const uint8_t* data, std::size_t size, uint16_t flags, PosePacket& out) {
  if ((flags & ~kPoseHasVelocity) != 0) return ParseResult::Malformed;
  out.has_velocity = (flags & kPoseHasVelocity) != 0;
  if (const ParseResult r = check_size(size, out.has_velocity ? kPoseWithVelocitySize : kPoseSize);
      r != ParseResult::Pose)
    return r;
  out.buttons = get_u32(data + 12);
  out.client_time = get_f64(data + 16);
  const Vec3 p = get_vec3(data + 24);
  const Quat q(get_f64(data + 48), get_f64(data + 56), get_f64(data + 64), get_f64(data + 72));
  out.velocity = out.has_velocity ? get_vec3(data + 80) : Vec3::Zero();
  out.angular_velocity = out.has_velocity ? get_vec3(data + 104) : Vec3::Zero();
  if (!std::isfinite(out.client_time) || !p.allFinite() || !q.coeffs().allFinite() ||
      !out.velocity.allFinite() || !out.angular_velocity.allFinite())
    return ParseResult::NonFinite;
  if (!is_unit(q)) return ParseResult::NonUnit;
  out.pose = Pose{p, q.normalized()};
  return ParseResult::Pose;
}

// Hello packet body (docs/device-bridge.md, "Hello").
ParseResult parse_hello_body(const uint8_t* data, std::size_t size, uint16_t flags, HelloPacket& out) {
  if (flags != 0) return ParseResult::Malformed;
  if (const ParseResult r = check_size(size, kHelloSize); r != ParseResult::Pose) return r;
  if (!all_zero(data + 12, 4)) return ParseResult::Malformed;
  out.client_time = get_f64(data + 16);
  out.max_force = get_f64(data + 24);
  out.max_stiffness = get_f64(data + 32);
  out.max_torque = get_f64(data + 40);
  out.workspace_min = get_vec3(data + 48);
  out.workspace_max = get_vec3(data + 72);
  std::memcpy(out.name.data(), data + 96, kDeviceNameSize);
  if (!std::isfinite(out.client_time) || !std::isfinite(out.max_force) || !std::isfinite(out.max_stiffness) ||
      !std::isfinite(out.max_torque) || !out.workspace_min.allFinite() || !out.workspace_max.allFinite())
    return ParseResult::NonFinite;
  if (!(out.max_force > 0.0) || !(out.max_stiffness > 0.0) || !(out.max_torque >= 0.0) ||
      !(out.workspace_min.array() <= out.workspace_max.array()).all())
    return ParseResult::Malformed;
  // The name: printable ASCII, then NUL padding to the end.
  std::size_t i = 0;
  while (i < kDeviceNameSize && out.name[i] != 0) {
    if (out.name[i] < 0x20 || out.name[i] > 0x7e) return ParseResult::Malformed;
    ++i;
  }
  for (; i < kDeviceNameSize; ++i)
    if (out.name[i] != 0) return ParseResult::Malformed;
  return ParseResult::Hello;
}

}  // namespace

std::string_view HelloPacket::name_view() const {
  std::size_t n = 0;
  while (n < name.size() && name[n] != 0) ++n;
  return {name.data(), n};
}

const char* parse_result_name(ParseResult result) {
  switch (result) {
    case ParseResult::Pose:
      return "pose";
    case ParseResult::Hello:
      return "hello";
    case ParseResult::Wrench:
      return "wrench";
    case ParseResult::Truncated:
      return "truncated";
    case ParseResult::Malformed:
      return "malformed";
    case ParseResult::BadMagic:
      return "bad_magic";
    case ParseResult::BadVersion:
      return "bad_version";
    case ParseResult::NonFinite:
      return "non_finite";
    case ParseResult::NonUnit:
      return "non_unit";
  }
  return "unknown";
}

ParseResult parse_client_packet(const uint8_t* data, std::size_t size, ClientPacket& out) {
  if (data == nullptr) return ParseResult::Truncated;
  if (const ParseResult r = check_header(data, size); r != ParseResult::Pose) return r;
  const uint16_t flags = get_u16(data + kOffFlags);
  const uint32_t sequence = get_u32(data + kOffSequence);
  // Dispatch on the type; a client never sends wrenches.
  switch (data[kOffType]) {
    case static_cast<uint8_t>(PacketType::Pose):
      out.type = PacketType::Pose;
      out.pose.sequence = sequence;
      return parse_pose_body(data, size, flags, out.pose);
    case static_cast<uint8_t>(PacketType::Hello):
      out.type = PacketType::Hello;
      out.hello.sequence = sequence;
      return parse_hello_body(data, size, flags, out.hello);
    default:
      return ParseResult::Malformed;
  }
}

ParseResult parse_wrench(const uint8_t* data, std::size_t size, WrenchPacket& out) {
  if (data == nullptr) return ParseResult::Truncated;
  if (const ParseResult r = check_header(data, size); r != ParseResult::Pose) return r;
  if (data[kOffType] != static_cast<uint8_t>(PacketType::Wrench)) return ParseResult::Malformed;
  if (const ParseResult r = check_size(size, kWrenchSize); r != ParseResult::Pose) return r;
  out.flags = get_u16(data + kOffFlags);
  out.sequence = get_u32(data + kOffSequence);
  out.state = data[12];
  if ((out.flags & ~kWrenchKnownFlags) != 0 || out.state > 3 || !all_zero(data + 13, 3))
    return ParseResult::Malformed;
  out.server_time = get_f64(data + 16);
  out.client_time = get_f64(data + 24);
  out.force = get_vec3(data + 32);
  out.torque = get_vec3(data + 56);
  out.depth = get_f64(data + 80);
  if (!std::isfinite(out.server_time) || !std::isfinite(out.client_time) || !out.force.allFinite() ||
      !out.torque.allFinite() || !std::isfinite(out.depth))
    return ParseResult::NonFinite;
  return ParseResult::Wrench;
}

std::size_t encode_pose(const PosePacket& packet, uint8_t* out, std::size_t capacity) {
  const std::size_t size = packet.has_velocity ? kPoseWithVelocitySize : kPoseSize;
  if (out == nullptr || capacity < size) return 0;
  put_header(out, PacketType::Pose, packet.has_velocity ? kPoseHasVelocity : 0, packet.sequence);
  put_u32(out + 12, packet.buttons);
  put_f64(out + 16, packet.client_time);
  put_vec3(out + 24, packet.pose.p);
  put_f64(out + 48, packet.pose.q.w());
  put_f64(out + 56, packet.pose.q.x());
  put_f64(out + 64, packet.pose.q.y());
  put_f64(out + 72, packet.pose.q.z());
  if (packet.has_velocity) {
    put_vec3(out + 80, packet.velocity);
    put_vec3(out + 104, packet.angular_velocity);
  }
  return size;
}

std::size_t encode_hello(const HelloPacket& packet, uint8_t* out, std::size_t capacity) {
  if (out == nullptr || capacity < kHelloSize) return 0;
  put_header(out, PacketType::Hello, 0, packet.sequence);
  put_u32(out + 12, 0);
  put_f64(out + 16, packet.client_time);
  put_f64(out + 24, packet.max_force);
  put_f64(out + 32, packet.max_stiffness);
  put_f64(out + 40, packet.max_torque);
  put_vec3(out + 48, packet.workspace_min);
  put_vec3(out + 72, packet.workspace_max);
  std::memcpy(out + 96, packet.name.data(), kDeviceNameSize);
  return kHelloSize;
}

std::size_t encode_wrench(const WrenchPacket& packet, uint8_t* out, std::size_t capacity) {
  if (out == nullptr || capacity < kWrenchSize) return 0;
  put_header(out, PacketType::Wrench, packet.flags, packet.sequence);
  out[12] = packet.state;
  out[13] = out[14] = out[15] = 0;
  put_f64(out + 16, packet.server_time);
  put_f64(out + 24, packet.client_time);
  put_vec3(out + 32, packet.force);
  put_vec3(out + 56, packet.torque);
  put_f64(out + 80, packet.depth);
  return kWrenchSize;
}

}  // namespace cariesim::bridge
