#pragma once
/// Haptic devices, in the shape of the haptics ecosystem (pose, velocity, buttons, set force and
/// torque, device info). The servo thread calls read() and write() once per cycle: implementations
/// must not block, lock, allocate or do slow I/O there. Backends: null, scripted trajectory, replay of
/// a recording, mouse (in the viewer), UDP bridge (docs/device-bridge.md).
///
/// The device module is a leaf (docs/architecture.md): it knows math and its own types only. What
/// the engine says goes in as plain codes (DeviceStatus); devices are made from spec strings one
/// level up, by the runtime (device/factory.hpp).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/device/limits.hpp"

namespace cariesim {

/// What a device is and what it can render.
struct DeviceInfo {
  std::string name;           ///< "null", "scripted", "replay", "mouse", "udp"
  std::string description;    ///< e.g. the file or port it uses, the remote device's model
  DeviceLimits limits;        ///< max force (N), stiffness (N/mm), torque (N·mm), workspace (mm)
  bool renders_force = true;  ///< false for the mouse: the force is only shown
};

/// What a device's buttons are mapped to (device/profile.hpp), as bits of DeviceState::actions: held
/// while the button is pressed.
enum DeviceAction : uint32_t {
  kActionClutch = 1u << 0,      ///< the virtual tool stays put while the hand re-centres
  kActionMarkMild = 1u << 1,    ///< mark a lesion at the tip, graded mild
  kActionMarkSevere = 1u << 2,  ///< mark a lesion at the tip, graded severe
  kActionEndCase = 1u << 3,     ///< the trainee is done with this case
};

/// One reading of the device.
struct DeviceState {
  Pose pose;                             ///< tool frame (origin at the tip sphere's centre) in the world
  Vec3 velocity = Vec3::Zero();          ///< mm/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
  uint32_t buttons = 0;                  ///< bit i = button i pressed
  uint32_t actions = 0;                  ///< DeviceAction bits of the pressed buttons (a profile's map)
  double stamp = 0.0;                    ///< s, servo-clock time at which this reading was taken/received
  uint64_t sequence = 0;                 ///< increases with every new reading
  bool valid = false;                    ///< false until the first reading (or when the source ended)
};

/// What the simulator reports alongside each wrench (the UDP bridge forwards it to its client).
struct DeviceStatus {
  /// The engine's interaction state as the bridge protocol's state byte (docs/device-bridge.md):
  /// 0 free, 1 sliding, 2 inserting, 3 extracting. The servo loop converts its InteractionState.
  uint8_t state = 0;
  double depth = 0.0;                ///< mm, insertion depth
  uint32_t safety_flags = 0;         ///< SafetyFlag bits: what force safety did (device/safety.hpp)
  uint32_t step_flags = 0;           ///< the engine step's flag bits (render/step.hpp StepFlag)
  bool limits_acknowledged = false;  ///< limits the device announced (poll_limits) are in force now
  bool force_clamped = false;        ///< the step's output stage clamped the force to the maximum
  bool torque_clamped = false;       ///< the same for the torque
};

/// What a device said about its limits (Device::poll_limits): limits it announced, or that the
/// announcement no longer holds.
struct LimitsAnnouncement {
  /// True when the last announcement was withdrawn (the UDP bridge: a new client that sent no
  /// hello): no announced limits apply any more, the scene's do.
  bool withdrawn = false;
  DeviceLimits limits;  ///< as announced (when not withdrawn)
};

/// A named event counter of a device (e.g. the UDP bridge's rejected packets), for panels and notes.
struct DeviceCounter {
  const char* name = "";  ///< static string, e.g. "rejected_stale"
  uint64_t value = 0;     ///< events so far
};

/// The clock of a device whose SDK owns the servo thread (OpenHaptics' scheduler, hdStartScheduler):
/// the servo loop does not start a thread of its own but runs its cycle inside the device's
/// callback, once per tick of the device, with the same timing report, safety and recording.
class DeviceClock {
 public:
  /// One servo cycle; called on the device's thread with the context given to start_clock.
  using Tick = void (*)(void* context);
  virtual ~DeviceClock() = default;
  /// Hz, the rate the device calls tick at.
  [[nodiscard]] virtual double rate_hz() const = 0;
  /// Starts calling tick(context) once per cycle on the device's thread, inside the SDK's frame (the
  /// tick's read() and write() of the device belong to that frame); throws cariesim::Error when the
  /// SDK refuses.
  virtual void start_clock(Tick tick, void* context) = 0;
  /// Stops calling tick; returns once the last tick has finished. Safe to call twice.
  virtual void stop_clock() = 0;
};

/// A haptic device. ServoLoop::start() calls start() and ServoLoop::stop() calls stop(), so a device
/// may be started again after a stop; start() on a running device does nothing.
class Device {
 public:
  virtual ~Device() = default;
  /// What the device is and what it can render (any thread; may allocate).
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
  /// The state that goes with the next write() (called just before it). Servo thread; non-blocking.
  virtual void set_status(const DeviceStatus& status) { (void)status; }
  /// What the device announced about its limits since the last call (e.g. a UDP client's hello, raw;
  /// or a new client without one: withdrawn): the servo loop checks announced limits and tightens
  /// the scene's to them, and goes back to the scene's when they are withdrawn. True, with `out` set,
  /// when there is news (the newest only). Servo thread; non-blocking, allocation-free. Devices that
  /// never announce anything return false.
  virtual bool poll_limits(LimitsAnnouncement& out) {
    (void)out;
    return false;
  }
  /// Event counters (any thread; may allocate). Empty for devices without any.
  [[nodiscard]] virtual std::vector<DeviceCounter> counters() const { return {}; }
  /// Non-null when the device clocks the servo loop (DeviceClock); valid after start().
  virtual DeviceClock* clock() { return nullptr; }
};

}  // namespace cariesim
