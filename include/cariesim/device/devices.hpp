#pragma once
/// The devices that need no hardware: `null` (holds the tool still) and `scripted:FILE[:loop]`
/// (follows a trajectory on the servo clock; device/factory.hpp reads it from a CSV file). The
/// UDP bridge is in udp_device.hpp, the replay device in replay.hpp, the mouse in the viewer.

#include <cstdint>
#include <string>

#include "cariesim/common/trajectory.hpp"
#include "cariesim/device/device.hpp"

namespace cariesim {

/// Holds the tool at a fixed pose (e.g. the scene's home) and renders nothing.
class NullDevice : public Device {
 public:
  explicit NullDevice(const Pose& pose, const DeviceLimits& limits = {}) : pose_(pose), limits_(limits) {}
  [[nodiscard]] DeviceInfo info() const override;
  DeviceState read(double now) override;
  void write(const Vec3& force, const Vec3& torque) override;

 private:
  Pose pose_;
  DeviceLimits limits_;
  uint64_t sequence_ = 0;
};

/// Follows a trajectory, sampled at the servo clock from the first read() after start(): time
/// `now - now_at_first_read` maps to `trajectory.start() + that`. Velocities are finite differences
/// between consecutive readings. After the end the reading holds the last pose and is invalid
/// (valid = false) unless `loop`, which starts the trajectory over.
class ScriptedDevice : public Device {
 public:
  /// Throws cariesim::Error when the trajectory is empty. `description` names it (e.g. the file).
  ScriptedDevice(Trajectory trajectory, bool loop, std::string description, const DeviceLimits& limits = {});
  ScriptedDevice(const ScriptedDevice&) = delete;  // the cursor points into this object's trajectory
  ScriptedDevice& operator=(const ScriptedDevice&) = delete;
  [[nodiscard]] DeviceInfo info() const override;
  /// Rewinds to the start of the trajectory.
  void start() override;
  DeviceState read(double now) override;
  void write(const Vec3& force, const Vec3& torque) override;
  /// The last wrench written (N), for tests and headless runs.
  [[nodiscard]] const Vec3& last_force() const { return force_; }
  [[nodiscard]] bool finished() const { return finished_; }  ///< the trajectory ended (never when looping)

 private:
  Trajectory trajectory_;
  TrajectoryCursor cursor_;
  bool loop_;
  std::string description_;
  DeviceLimits limits_;
  bool started_ = false;       // the first read after start() happened
  double origin_ = 0.0;        // s, servo time of that first read
  double previous_now_ = 0.0;  // s
  Pose previous_pose_;
  bool finished_ = false;
  uint64_t sequence_ = 0;
  Vec3 force_ = Vec3::Zero();
};

}  // namespace cariesim
