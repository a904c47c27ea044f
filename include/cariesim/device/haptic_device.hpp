#pragma once
/// The Device a real haptic device is (docs/devices.md): a HardwareDevice (one vendor SDK) behind a
/// profile (device/profile.hpp). One class for every backend does what makes a hand drive the scene:
///
/// - Mapping. A reading (device frame, mm) becomes a tool pose in the scene:
///     p_tool = R * (s * axes * p_device + c) + t + q_tool * stylus_offset
///     q_tool = R * axes * q_device * q_stylus
///   with R and s the profile's rotation and scale, axes the backend's (HardwareInfo::axes), t the
///   profile's translation (default: the tool home) less the workspace centre's image, c the clutch's
///   accumulated offset, and q_stylus chosen so that the stylus's rest orientation is the tool home's.
///   A device that senses no orientation (dof_in 3) holds the profile's fixed orientation.
///   Velocities scale the same way. A wrench goes back through the inverse rotation; the force is the
///   tool's (a scale s makes the hand feel a stiffness s times the scene's, so the maximum stiffness
///   the device announces is its own divided by s).
/// - Clutch. While the clutch button is held the tool stays where it was and the device renders no
///   force; on release the offset c takes up the hand's move, so the tool goes on from where it stood
///   (no jump), and the force ramps in again (no step), as CHAI3D's re-indexing does.
/// - Buttons to actions (DeviceState::actions) through the profile's map.
/// - Torque on a 3-DoF-force device: it cannot be rendered; the force alone is (at the device point)
///   and every cycle with a torque that was dropped is counted (counter "torque_dropped"), the largest
///   dropped torque kept (torque_dropped_max). A 6-DoF-force device gets the torque about its device
///   point (the tip's torque plus the lever of the stylus offset), within its torque limit.
/// - Enabling the force. The device's force switch turns on only when it is calibrated (homed) and
///   the commanded force is below profile.force_enable_below (the tool is out of contact), as CHAI3D
///   waits for a small force; then the force ramps in over profile.ramp_time. A hardware fault,
///   an invalid reading or a stop zeroes the force in the same cycle; close switches the force off.
/// - Limits. The device's nominal peak force, torque and stiffness (over s) are announced to the servo
///   loop (poll_limits), which tightens the scene's; sustained loads are held to the continuous
///   (thermal) force: a first-order model of the mean square force over
///   profile.continuous_time_constant, and the force scaled so its mean square stays within
///   continuous_force².

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/device/device.hpp"
#include "cariesim/device/hardware.hpp"
#include "cariesim/device/profile.hpp"

namespace cariesim {

/// What a HapticDevice is doing, for the viewer's panel and the status file (any thread).
struct HapticStatus {
  HardwareInfo hardware;
  Calibration calibration;    ///< the last calibrate() result
  bool force_enabled = false; ///< the device's force switch is on
  bool clutched = false;      ///< the clutch is held
  uint32_t faults = 0;        ///< HardwareFault bits of the last reading
  uint64_t torque_dropped = 0;    ///< cycles whose torque a 3-DoF-force device could not render
  double torque_dropped_max = 0.0;///< N·mm, the largest of them
  uint64_t continuous_limited = 0;///< cycles the continuous (thermal) limit scaled the force down
  /// "3-DoF force: the torque (posture cue) is not rendered" or "6-DoF force and torque".
  [[nodiscard]] std::string rendering() const;
};

class HapticDevice : public Device {
 public:
  /// Takes the device (not yet opened) and its profile; `home` is the scene's tool home (where the
  /// workspace centre and the rest orientation map to by default). Nothing is opened before start().
  HapticDevice(std::unique_ptr<HardwareDevice> hardware, DeviceProfile profile, const Pose& home);
  ~HapticDevice() override;
  HapticDevice(const HapticDevice&) = delete;
  HapticDevice& operator=(const HapticDevice&) = delete;

  /// name: the backend; description: model, serial, SDK; limits: the device's (over the scale).
  [[nodiscard]] DeviceInfo info() const override;
  /// Opens the device, calibrates (homes) it, sets up the mapping; when the operator must act
  /// (Readiness::NeedsOperator) a watcher thread calls calibrate() again until the device is ready,
  /// and force stays off meanwhile. Throws cariesim::Error from open() or a failed calibration.
  void start() override;
  /// Switches force off and closes the device.
  void stop() override;
  DeviceState read(double now) override;
  void write(const Vec3& force, const Vec3& torque) override;
  bool poll_limits(LimitsAnnouncement& out) override;
  [[nodiscard]] std::vector<DeviceCounter> counters() const override;
  DeviceClock* clock() override { return hardware_->clock(); }

  /// The panel's view of the device (any thread).
  [[nodiscard]] HapticStatus status() const;
  [[nodiscard]] const DeviceProfile& profile() const { return profile_; }
  /// The hardware behind it (tests).
  [[nodiscard]] HardwareDevice& hardware() { return *hardware_; }

 private:
  void watch_calibration();
  std::unique_ptr<HardwareDevice> hardware_;
  DeviceProfile profile_;
  Pose home_;
  HardwareInfo info_;
  DeviceLimits limits_;  // what the device can render, in the scene (set at start; announced)
  // Mapping (set at start): scene position = map_q_ * (scale * device) + map_t_ + clutch_offset_.
  Quat map_q_ = Quat::Identity();  // profile rotation * backend axes
  Vec3 map_t_ = Vec3::Zero();      // mm
  Quat stylus_q_ = Quat::Identity();
  // Servo thread.
  Vec3 clutch_offset_ = Vec3::Zero();  // mm, scene
  Pose last_pose_;                     // the tool pose last read
  Pose clutch_pose_;                   // the tool pose held while clutched
  bool clutch_held_ = false;
  bool limits_sent_ = false;
  bool enabled_ = false;
  double now_ = 0.0;            // s, servo time of the last read
  double ramp_start_ = -1.0;    // s, when the force last started ramping in
  double mean_square_ = 0.0;    // N², the thermal model's state
  double last_square_ = 0.0;    // N², the squared force written last
  double last_write_ = -1.0;    // s
  uint32_t faults_ = 0;
  bool reading_valid_ = false;
  uint64_t sequence_ = 0;
  // Shared with other threads.
  std::atomic<bool> ready_{false};
  std::atomic<bool> force_on_{false};
  std::atomic<bool> clutched_{false};
  std::atomic<uint32_t> last_faults_{0};
  std::atomic<uint64_t> torque_dropped_{0};
  std::atomic<double> torque_dropped_max_{0.0};
  std::atomic<uint64_t> continuous_limited_{0};
  mutable std::mutex calibration_mutex_;  // guards calibration_ (never taken on the servo thread)
  Calibration calibration_;
  std::atomic<bool> watching_{false};
  std::thread watcher_;
};

}  // namespace cariesim
