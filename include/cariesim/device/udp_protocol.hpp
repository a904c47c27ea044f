#pragma once
/// The UDP bridge's wire protocol (docs/device-bridge.md describes it byte by byte): a small
/// versioned little-endian binary protocol through which any lab device program (OpenHaptics,
/// Force Dimension, CHAI3D) drives the simulator. Client -> simulator: pose packets (tool pose,
/// optionally velocity, buttons) and a hello packet announcing the device's limits. Simulator ->
/// client: wrench packets (force, torque, interaction state, insertion depth, wrench flags) that echo
/// the sequence number of the pose they answer.
///
/// The parser is strict: a datagram is accepted only when every byte has its documented meaning.
/// Encoding and parsing allocate nothing.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "cariesim/common/math.hpp"
#include "cariesim/device/limits.hpp"

namespace cariesim::bridge {

inline constexpr uint32_t kMagic = 0x4D495343u;  ///< the bytes 'C' 'S' 'I' 'M' read as a little-endian u32
inline constexpr uint8_t kVersion = 1;           ///< protocol version this build speaks

/// The packet type (byte 5 of every packet).
enum class PacketType : uint8_t {
  Pose = 0x01,    ///< client -> simulator: the tool pose
  Hello = 0x02,   ///< client -> simulator: device limits; starts a session
  Wrench = 0x81,  ///< simulator -> client: force and torque answering a pose
};

/// Pose packet flags (bytes 6-7).
enum PoseFlag : uint16_t {
  kPoseHasVelocity = 1u << 0,  ///< 48 more bytes: linear (mm/s) and angular (rad/s) velocity
};
/// Wrench packet flags (bytes 6-7, docs/device-bridge.md "Wrench"): the protocol's own word, what
/// happened to this wrench on its way out. The bridge composes it from the cycle's DeviceStatus.
enum WrenchFlag : uint16_t {
  kWrenchForceClamped = 1u << 0,         ///< the step's output stage clamped the force to the maximum
  kWrenchTorqueClamped = 1u << 1,        ///< the same for the torque
  kWrenchRamping = 1u << 2,              ///< force safety is ramping in (after start or a fault)
  kWrenchInputStale = 1u << 3,           ///< the pose is stale; the wrench is zero
  kWrenchInputNonFinite = 1u << 4,       ///< the pose (or the wrench) is not finite; the wrench is zero
  kWrenchInputInvalid = 1u << 5,         ///< no valid pose (none yet); the wrench is zero
  kWrenchInputJump = 1u << 6,            ///< the pose jumped (turned); the wrench is zero this cycle
  kWrenchLimitsAcknowledged = 1u << 15,  ///< a hello's limits are in force
};
/// Every defined wrench flag; the other bits are reserved (0).
inline constexpr uint16_t kWrenchKnownFlags =
    kWrenchForceClamped | kWrenchTorqueClamped | kWrenchRamping | kWrenchInputStale | kWrenchInputNonFinite |
    kWrenchInputInvalid | kWrenchInputJump | kWrenchLimitsAcknowledged;

inline constexpr std::size_t kHeaderSize = 12;             ///< bytes: magic, version, type, flags, sequence
inline constexpr std::size_t kPoseSize = 80;               ///< bytes, pose packet without velocity
inline constexpr std::size_t kPoseWithVelocitySize = 128;  ///< bytes, pose packet with velocity
inline constexpr std::size_t kHelloSize = 128;             ///< bytes
inline constexpr std::size_t kWrenchSize = 88;             ///< bytes
inline constexpr std::size_t kMaxPacketSize = 128;         ///< bytes, the largest valid packet
inline constexpr std::size_t kDeviceNameSize = 32;         ///< bytes, NUL-padded ASCII in a hello

/// A pose packet (client -> simulator).
struct PosePacket {
  uint32_t sequence = 0;                 ///< increases by one with every packet the client sends
  uint32_t buttons = 0;                  ///< bit i = button i pressed
  double client_time = 0.0;              ///< s, the client's clock when the pose was read
  Pose pose;                             ///< tool frame in the simulator's world (mm, unit quaternion)
  bool has_velocity = false;             ///< the velocities below were sent
  Vec3 velocity = Vec3::Zero();          ///< mm/s, world
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world
};

/// A hello packet (client -> simulator): the device's limits; starts a new session.
struct HelloPacket {
  uint32_t sequence = 0;                     ///< the client's sequence counter (poses continue after it)
  double client_time = 0.0;                  ///< s, the client's clock
  double max_force = 0.0;                    ///< N, > 0
  double max_stiffness = 0.0;                ///< N/mm, > 0
  double max_torque = 0.0;                   ///< N·mm, >= 0 (0: the device renders no torque)
  Vec3 workspace_min = Vec3::Zero();         ///< mm, world
  Vec3 workspace_max = Vec3::Zero();         ///< mm, world
  std::array<char, kDeviceNameSize> name{};  ///< device model, printable ASCII, NUL-padded

  /// The name without its padding.
  [[nodiscard]] std::string_view name_view() const;
};

/// A wrench packet (simulator -> client).
struct WrenchPacket {
  uint32_t sequence = 0;       ///< echo of the pose packet this wrench answers
  uint16_t flags = 0;          ///< WrenchFlag bits
  uint8_t state = 0;           ///< interaction state: 0 free, 1 sliding, 2 inserting, 3 extracting
  double server_time = 0.0;    ///< s, the simulator's servo clock
  double client_time = 0.0;    ///< s, echo of that pose packet's client time
  Vec3 force = Vec3::Zero();   ///< N, world, at the tool-frame origin (the tip sphere's centre)
  Vec3 torque = Vec3::Zero();  ///< N·mm, world, about the tool-frame origin
  double depth = 0.0;          ///< mm, insertion depth
};

/// What parsing a datagram found.
enum class ParseResult : uint8_t {
  Pose,        ///< a valid pose packet
  Hello,       ///< a valid hello packet
  Wrench,      ///< a valid wrench packet (parse_wrench only)
  Truncated,   ///< shorter than its header or its type needs
  Malformed,   ///< too long, unknown type or flag bits, non-zero reserved bytes, values out of range
  BadMagic,    ///< the first four bytes are not kMagic
  BadVersion,  ///< a protocol version other than kVersion
  NonFinite,   ///< a NaN or infinite number
  NonUnit,     ///< the quaternion is not unit (is_unit, device/input_guard.hpp: within kUnitTolerance)
};
/// "pose", "truncated", ...
const char* parse_result_name(ParseResult result);

/// One parsed client packet: `type` says which member holds it.
struct ClientPacket {
  PacketType type = PacketType::Pose;
  PosePacket pose;
  HelloPacket hello;
};

/// Parses a datagram from a client. On Pose or Hello, `out` holds the packet (a pose's quaternion
/// normalised); on any other result `out` is unspecified.
ParseResult parse_client_packet(const uint8_t* data, std::size_t size, ClientPacket& out);
/// Parses a datagram from the simulator (for clients and tests): Wrench or the reason it is not one.
ParseResult parse_wrench(const uint8_t* data, std::size_t size, WrenchPacket& out);

/// Writes a pose packet (kPoseSize or kPoseWithVelocitySize bytes); returns the size, 0 when
/// `capacity` is too small.
std::size_t encode_pose(const PosePacket& packet, uint8_t* out, std::size_t capacity);
/// Writes a hello packet (kHelloSize bytes); returns the size, 0 when `capacity` is too small.
std::size_t encode_hello(const HelloPacket& packet, uint8_t* out, std::size_t capacity);
/// Writes a wrench packet (kWrenchSize bytes); returns the size, 0 when `capacity` is too small.
std::size_t encode_wrench(const WrenchPacket& packet, uint8_t* out, std::size_t capacity);

}  // namespace cariesim::bridge
