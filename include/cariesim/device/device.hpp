#pragma once
/// Haptic devices, in the shape of the haptics ecosystem (pose, velocity, buttons, set force and
/// torque, device info). The servo thread calls read() and write() once per cycle: implementations
/// must not block, lock, allocate or do slow I/O there. Backends: null, scripted trajectory, replay of
/// a recording, mouse (in the viewer), UDP bridge (docs/device-bridge.md).

#include <cstdint>
#include <memory>
#include <string>

#include "cariesim/common/math.hpp"
#include "cariesim/render/model.hpp"

namespace cariesim {

/// What a device is and what it can render.
struct DeviceInfo {
  std::string name;               ///< "null", "scripted", "replay", "mouse", "udp"
  std::string description;        ///< e.g. the file or port it uses, the remote device's model
  DeviceLimits limits;            ///< max force (N), stiffness (N/mm), torque (N·mm), workspace (mm)
  bool renders_force = true;      ///< false for the mouse: the force is only shown
};

/// One reading of the device.
struct DeviceState {
  Pose pose;                          ///< tool frame (origin at the tip sphere's centre) in the world
  Vec3 velocity = Vec3::Zero();       ///< mm/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
  uint32_t buttons = 0;               ///< bit i = button i pressed
  double stamp = 0.0;                 ///< s, servo-clock time at which this reading was taken/received
  uint64_t sequence = 0;              ///< increases with every new reading
  bool valid = false;                 ///< false until the first reading (or when the source ended)
};

class Device {
 public:
  virtual ~Device() = default;
  [[nodiscard]] virtual DeviceInfo info() const = 0;
  /// Starts the device (threads, sockets); throws cariesim::Error with the reason when it cannot.
  virtual void start() {}
  /// Stops it; safe to call twice.
  virtual void stop() {}
  /// The latest reading at servo time `now` (s). Servo thread; non-blocking.
  virtual DeviceState read(double now) = 0;
  /// Renders a wrench (N, N·mm, at the tool-frame origin) that already went through ForceSafety.
  /// Servo thread; non-blocking.
  virtual void write(const Vec3& force, const Vec3& torque) = 0;
};

}  // namespace cariesim
