#pragma once
/// A real haptic device behind its vendor's SDK (docs/devices.md): OpenHaptics HD (`touch`), Force
/// Dimension DHD/DRD (`fd`), Haply's Inverse Service (`haply`). A backend speaks its SDK and nothing
/// more: it converts the SDK's units to the project's (mm, N, N·mm, s) but keeps the device's own axes,
/// which it states (HardwareInfo::axes). Everything that makes a hand drive a scene (the profile's
/// frame mapping and scale, the stylus offset, the clutch, buttons to actions, what a 3-DoF-force
/// device gets of the torque, enabling and ramping the force, the continuous-force limit) is one class
/// above every backend, HapticDevice (device/haptic_device.hpp), which is the `Device` the servo loop
/// drives.
///
/// Threads: open(), calibrate(), info() and close() run on the thread that starts and stops the
/// device (never the servo thread). read(), write() and enable_force() run on the servo thread: they
/// must not allocate, lock or block. A backend whose SDK owns the servo clock (OpenHaptics' scheduler)
/// returns a DeviceClock (device/device.hpp) and the servo loop runs its cycle inside the SDK's
/// callback; the others are driven by the servo loop's own thread.

#include <cstdint>
#include <string>

#include "cariesim/common/math.hpp"
#include "cariesim/device/device.hpp"

namespace cariesim {

/// The operator frame every backend's axes are stated in: x to the operator's right, y away from the
/// operator, z up. It is the scene's world frame seen by an operator facing the patient (docs/scene-
/// format.md: x toward the patient's left, y toward the back, z up), so the default profile maps it
/// onto the scene with no rotation.
///
/// What a device is and can do, in the project's units; positions in the device's own frame.
struct HardwareInfo {
  std::string backend;  ///< "touch", "fd", "haply"
  std::string model;    ///< e.g. "Touch", "Phantom Premium 1.5 6DOF", "omega.6", "Falcon", "Inverse3"
  std::string serial;   ///< the SDK's serial number or device id ("" when it tells none)
  std::string sdk;      ///< the library's path and version, e.g. "/usr/lib/libHD.so 3.4.0"
  int dof_in = 6;       ///< 3: position only (the Falcon, an Inverse3 without a VerseGrip); 6: with orientation
  int dof_out = 3;      ///< 3: force only; 6: force and torque (Phantom Premium 6-DoF, sigma.7, lambda.7)
  int buttons = 0;      ///< number of buttons (bit i of HardwareReading::buttons is button i)
  double max_force = 0.0;         ///< N, nominal peak force
  double continuous_force = 0.0;  ///< N, the force the motors sustain (thermal limit)
  double max_stiffness = 0.0;     ///< N/mm, the stiffest spring the device renders stably
  double max_torque = 0.0;        ///< N·mm, nominal peak torque (0 when dof_out is 3)
  Eigen::AlignedBox3d workspace{Vec3::Zero(), Vec3::Zero()};  ///< mm, the device point's reach, device frame
  double rate_hz = 1000.0;  ///< Hz, the servo rate the device runs at (its own clock) or is meant for
  /// The device's axes in the operator frame: p_operator = axes * p_device (a rotation). OpenHaptics:
  /// x right, y up, z toward the user; Force Dimension: x toward the operator, y right, z up.
  Quat axes = Quat::Identity();
  /// The end effector's orientation (device frame) when the stylus rests in its inkwell or holder:
  /// the default profile maps it onto the scene's tool home orientation.
  Quat rest_orientation = Quat::Identity();
};

/// What went wrong in the SDK, as bits (HardwareReading::faults). Any fault makes the reading
/// invalid, so force safety zeroes the force in the same cycle.
enum HardwareFault : uint32_t {
  kHardwareCommunication = 1u << 0,     ///< lost contact with the device (cable, USB, the service)
  kHardwareOverheat = 1u << 1,          ///< motors too warm (OpenHaptics HD_WARM_MOTORS)
  kHardwareForceExceeded = 1u << 2,     ///< the SDK refused a force above its limit
  kHardwareVelocityExceeded = 1u << 3,  ///< the stylus moved faster than the SDK allows
  kHardwareNotCalibrated = 1u << 4,     ///< calibration or homing is needed
  kHardwareLost = 1u << 5,              ///< the device is gone (unplugged, service stopped)
  kHardwareOther = 1u << 6,             ///< any other SDK error
};

/// "communication error, motors too warm" for HardwareFault bits; "" for none.
std::string describe_hardware_faults(uint32_t faults);

/// One reading, in the project's units and the device's frame.
struct HardwareReading {
  Pose pose;  ///< the device point (mm) and the end effector's orientation (identity when dof_in is 3)
  Vec3 velocity = Vec3::Zero();          ///< mm/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
  uint32_t buttons = 0;                  ///< bit i = button i pressed
  uint32_t faults = 0;                   ///< HardwareFault bits of this cycle
  bool valid = false;                    ///< a fresh reading without a fault
};

/// Whether force may be enabled (HardwareDevice::calibrate).
enum class Readiness {
  Ready,         ///< calibrated or homed
  NeedsOperator, ///< the operator must act: put the stylus in the inkwell, home the Falcon by hand
  Failed,        ///< calibration or homing failed; the message says why
};

/// What calibrate() found and what the operator is asked to do.
struct Calibration {
  Readiness readiness = Readiness::Failed;
  std::string message;  ///< e.g. "put the stylus in the inkwell", "homing (robotic): done"
};

/// One device of one SDK (the SDK loaded with device/shared_library.hpp).
class HardwareDevice {
 public:
  virtual ~HardwareDevice() = default;
  /// Opens the device; throws cariesim::Error naming the cause (no device, busy, no permission with
  /// the udev rule to add, an SDK error code in words). Opening an open device does nothing.
  virtual void open() = 0;
  /// Switches the device's force off and closes it; safe to call twice and on a device never opened.
  virtual void close() = 0;
  /// What the device is (after open()).
  [[nodiscard]] virtual HardwareInfo info() const = 0;
  /// Checks calibration (homing) and runs what the SDK does by itself (OpenHaptics' automatic
  /// calibration update, Force Dimension's robotic homing); may take seconds. After open(), before
  /// the servo loop starts or from another thread while the device's force is off.
  virtual Calibration calibrate() = 0;
  /// The latest reading. Servo thread: non-blocking, allocation-free.
  virtual HardwareReading read() = 0;
  /// Renders a wrench at the device point: N and N·mm in the device's frame (a backend converts to
  /// its SDK's units; a 3-DoF-output device ignores the torque). Servo thread: non-blocking.
  virtual void write(const Vec3& force, const Vec3& torque) = 0;
  /// The device's own force switch (hdEnable(HD_FORCE_OUTPUT), dhdEnableForce). Servo thread.
  virtual void enable_force(bool on) = 0;
  /// Non-null when the SDK owns the servo clock.
  virtual DeviceClock* clock() { return nullptr; }
};

}  // namespace cariesim
