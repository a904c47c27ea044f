// The `fd` backend (docs/devices.md, "Force Dimension"): omega, sigma, lambda, delta and the Novint
// Falcon through Force Dimension's DHD/DRD SDK, loaded at run time (device/shared_library.hpp). The
// application owns the loop: the servo thread calls the SDK's getters and setters directly. The SDK
// speaks m, m/s, N and N·m in the device's frame (x toward the operator, y right, z up); this backend
// converts to mm, mm/s, N and N·mm and keeps the frame, which it states in HardwareInfo::axes.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <thread>
#include <utility>

#include "cariesim/common/error.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "device/fd_api.hpp"

namespace cariesim {

namespace {

constexpr const char* kWhat = "Force Dimension SDK";
constexpr const char* kEnvVar = "CARIESIM_FD_LIBRARY";
constexpr const char* kInstall =
    "install Force Dimension's SDK for Linux (3.3 or newer, from forcedimension.com) and put its "
    "lib/ on the loader's path (copy libdrd.so.3 to /usr/local/lib and run ldconfig), or set "
    "CARIESIM_FD_LIBRARY to libdrd.so.3's path (docs/devices.md, \"Force Dimension\")";
constexpr const char* kUdevHint =
    "if `lsusb` lists it, this user may not open it: add the udev rule of docs/devices.md "
    "(\"Force Dimension\": /etc/udev/rules.d/99-forcedimension.rules), then unplug and plug it again";
constexpr double kMmPerM = 1000.0;
constexpr int kMaxIndex = 15;  // an argument up to this is an index, above it a serial number
// Communication errors in this many reads in a row (0.1 s at 1 kHz) mean the device is gone.
constexpr int kLostAfter = 100;
// How often the reopen thread looks for a lost device, and tries to open it again.
constexpr std::chrono::milliseconds kReopenPoll{50};
constexpr std::chrono::milliseconds kReopenRetry{250};

// What the backend knows of each model: data-sheet figures, conservative where the sheets differ.
struct Model {
  int type;
  const char* name;
  int dof_in;
  int dof_out;
  bool gripper;  // an active gripper: written with dhdSetForceAndTorqueAndGripperForce
  int buttons;
  double max_force;         // N
  double continuous_force;  // N
  double max_stiffness;     // N/mm
  double max_torque;        // N·mm
  double radius;            // mm, half the workspace's width (x, y)
  double half_height;       // mm, half its height (z)
};

constexpr std::array<Model, 15> kModels = {{
    {fd::kDeviceOmega3, "omega.3", 3, 3, false, 1, 12.0, 12.0, 14.5, 0.0, 80.0, 55.0},
    {fd::kDeviceOmega33, "omega.6", 6, 3, false, 1, 12.0, 12.0, 14.5, 0.0, 80.0, 55.0},
    {fd::kDeviceOmega33Left, "omega.6 left", 6, 3, false, 1, 12.0, 12.0, 14.5, 0.0, 80.0, 55.0},
    {fd::kDeviceOmega331, "omega.7", 6, 3, true, 1, 12.0, 12.0, 14.5, 0.0, 80.0, 55.0},
    {fd::kDeviceOmega331Left, "omega.7 left", 6, 3, true, 1, 12.0, 12.0, 14.5, 0.0, 80.0, 55.0},
    {fd::kDeviceDelta3, "delta.3", 3, 3, false, 1, 20.0, 20.0, 14.5, 0.0, 200.0, 130.0},
    {fd::kDeviceDelta6, "delta.6", 6, 6, false, 1, 20.0, 20.0, 14.5, 150.0, 200.0, 130.0},
    {fd::kDeviceSigma331, "sigma.7", 6, 6, true, 1, 20.0, 20.0, 14.0, 400.0, 95.0, 65.0},
    {fd::kDeviceSigma331Left, "sigma.7 left", 6, 6, true, 1, 20.0, 20.0, 14.0, 400.0, 95.0, 65.0},
    {fd::kDeviceSigma33p, "sigma.6+", 6, 6, false, 1, 20.0, 20.0, 14.0, 400.0, 95.0, 65.0},
    {fd::kDeviceSigma33pLeft, "sigma.6+ left", 6, 6, false, 1, 20.0, 20.0, 14.0, 400.0, 95.0, 65.0},
    {fd::kDeviceLambda331, "lambda.7", 6, 6, true, 1, 20.0, 20.0, 14.0, 300.0, 120.0, 90.0},
    {fd::kDeviceLambda331Left, "lambda.7 left", 6, 6, true, 1, 20.0, 20.0, 14.0, 300.0, 120.0, 90.0},
    {fd::kDeviceFalcon, "Falcon", 3, 3, false, 4, 8.9, 4.0, 3.0, 0.0, 50.0, 50.0},
    // Any other system type: position and force only, with the smallest figures above.
    {fd::kDeviceNone, "unknown Force Dimension device", 3, 3, false, 1, 8.0, 4.0, 3.0, 0.0, 50.0, 50.0},
}};

const Model& model_of(int type) {
  for (const Model& m : kModels)
    if (m.type == type) return m;
  return kModels.back();
}

// The SDK's version as text.
std::string version_text(const std::array<int, 4>& v) {
  return std::to_string(v[0]) + "." + std::to_string(v[1]) + "." + std::to_string(v[2]) + "." +
         std::to_string(v[3]);
}

// The SDK: the loaded library and every function the backend calls, resolved once.
struct FdSdk {
  SharedLibrary library;
  std::array<int, 4> version{};
  fd::GetDeviceCount get_device_count = nullptr;
  fd::OpenId open_id = nullptr;
  fd::OpenSerial open_serial = nullptr;
  fd::Close close = nullptr;
  fd::GetSystemType get_system_type = nullptr;
  fd::GetSystemName get_system_name = nullptr;
  fd::GetSerialNumber get_serial_number = nullptr;
  fd::EnableForce enable_force = nullptr;
  fd::GetPosition get_position = nullptr;
  fd::GetOrientationFrame get_orientation_frame = nullptr;
  fd::GetLinearVelocity get_linear_velocity = nullptr;
  fd::GetAngularVelocityRad get_angular_velocity = nullptr;
  fd::GetButtonMask get_button_mask = nullptr;
  fd::SetForceAndTorque set_force_and_torque = nullptr;
  fd::SetForceAndTorqueAndGripperForce set_force_torque_gripper = nullptr;
  fd::ErrorGetLast error_get_last = nullptr;
  fd::ErrorGetLastStr error_get_last_str = nullptr;
  // DRD (libdrd.so.3); all null with libdhd.so.3 alone, which cannot home a device.
  fd::DrdOpenId drd_open_id = nullptr;
  fd::DrdClose drd_close = nullptr;
  fd::DrdIsInitialized drd_is_initialized = nullptr;
  fd::DrdAutoInit drd_auto_init = nullptr;
  fd::DrdStop drd_stop = nullptr;

  explicit FdSdk(SharedLibrary lib) : library(std::move(lib)) {}
  [[nodiscard]] bool has_drd() const { return drd_open_id != nullptr; }
  [[nodiscard]] std::string describe() const { return library.path() + " " + version_text(version); }
  // The SDK's last error in words, with its code.
  [[nodiscard]] std::string last_error() const {
    const char* text = error_get_last_str();
    return std::string(text != nullptr ? text : "no description") + " (DHD error " +
           std::to_string(error_get_last()) + ")";
  }
};

// Loads the SDK; `version` is set as soon as it is known (for the survey of an SDK too old). The
// version is checked before any other symbol is resolved: an old SDK lacks some, and the version is
// what the user must be told about.
std::shared_ptr<FdSdk> load_sdk(std::string* version = nullptr) {
  auto sdk =
      std::make_shared<FdSdk>(SharedLibrary::open(kWhat, {"libdrd.so.3", "libdhd.so.3"}, kEnvVar, kInstall));
  const SharedLibrary& lib = sdk->library;
  auto get_version = lib.symbol<fd::GetSdkVersion>("dhdGetSDKVersion");
  std::array<int, 4>& v = sdk->version;
  get_version(&v[0], &v[1], &v[2], &v[3]);
  if (version != nullptr) *version = version_text(v);
  const auto& min = fd::kMinimumVersion;
  if (std::lexicographical_compare(v.begin(), v.begin() + 3, min.begin(), min.end()))
    throw Error(std::string(kWhat) + " (" + lib.path() + ") is version " + version_text(v) + ", older than " +
                std::to_string(min[0]) + "." + std::to_string(min[1]) + "." + std::to_string(min[2]) +
                ", the oldest with the functions cariesim uses (dhdSetForceAndTorqueAndGripperForce); " +
                kInstall);

  // The haptic functions, each required.
  sdk->get_device_count = lib.symbol<fd::GetDeviceCount>("dhdGetDeviceCount");
  sdk->open_id = lib.symbol<fd::OpenId>("dhdOpenID");
  sdk->open_serial = lib.symbol<fd::OpenSerial>("dhdOpenSerial");
  sdk->close = lib.symbol<fd::Close>("dhdClose");
  sdk->get_system_type = lib.symbol<fd::GetSystemType>("dhdGetSystemType");
  sdk->get_system_name = lib.symbol<fd::GetSystemName>("dhdGetSystemName");
  sdk->get_serial_number = lib.symbol<fd::GetSerialNumber>("dhdGetSerialNumber");
  sdk->enable_force = lib.symbol<fd::EnableForce>("dhdEnableForce");
  sdk->get_position = lib.symbol<fd::GetPosition>("dhdGetPosition");
  sdk->get_orientation_frame = lib.symbol<fd::GetOrientationFrame>("dhdGetOrientationFrame");
  sdk->get_linear_velocity = lib.symbol<fd::GetLinearVelocity>("dhdGetLinearVelocity");
  sdk->get_angular_velocity = lib.symbol<fd::GetAngularVelocityRad>("dhdGetAngularVelocityRad");
  sdk->get_button_mask = lib.symbol<fd::GetButtonMask>("dhdGetButtonMask");
  sdk->set_force_and_torque = lib.symbol<fd::SetForceAndTorque>("dhdSetForceAndTorque");
  sdk->set_force_torque_gripper =
      lib.symbol<fd::SetForceAndTorqueAndGripperForce>("dhdSetForceAndTorqueAndGripperForce");
  sdk->error_get_last = lib.symbol<fd::ErrorGetLast>("dhdErrorGetLast");
  sdk->error_get_last_str = lib.symbol<fd::ErrorGetLastStr>("dhdErrorGetLastStr");

  // The robotic functions: all of them when the library has DRD (libdrd.so.3), none with libdhd.
  if (lib.find("drdOpenID") != nullptr) {
    sdk->drd_open_id = lib.symbol<fd::DrdOpenId>("drdOpenID");
    sdk->drd_close = lib.symbol<fd::DrdClose>("drdClose");
    sdk->drd_is_initialized = lib.symbol<fd::DrdIsInitialized>("drdIsInitialized");
    sdk->drd_auto_init = lib.symbol<fd::DrdAutoInit>("drdAutoInit");
    sdk->drd_stop = lib.symbol<fd::DrdStop>("drdStop");
  }
  return sdk;
}

// HardwareFault bits of an SDK error code met on the servo thread.
uint32_t faults_of(int code) {
  switch (code) {
    case fd::kErrorCom:
    case fd::kErrorTimeout:
    case fd::kErrorDhcBusy:
      return kHardwareCommunication;
    case fd::kErrorNoDeviceFound:
    case fd::kErrorNotAvailable:
    case fd::kErrorInvalidIndex:
      return kHardwareLost;
    case fd::kErrorDeviceNotReady:
      return kHardwareNotCalibrated;
    default:
      return kHardwareOther;
  }
}

// Which device the spec names: an index (0-15) or a serial number.
struct Target {
  bool by_serial = false;
  int value = 0;
  [[nodiscard]] std::string describe() const {
    return (by_serial ? "serial " : "index ") + std::to_string(value);
  }
};

Target parse_target(std::string_view argument) {
  Target t;
  if (argument.empty()) return t;
  const auto [end, ec] = std::from_chars(argument.data(), argument.data() + argument.size(), t.value);
  if (ec != std::errc() || end != argument.data() + argument.size() || t.value < 0)
    throw Error("fd: '" + std::string(argument) +
                "' is neither a device index (0-15) nor a serial number (expected fd[:INDEX|SERIAL])");
  t.by_serial = t.value > kMaxIndex;
  return t;
}

// One Force Dimension device.
class FdDevice final : public HardwareDevice {
 public:
  FdDevice(std::shared_ptr<const FdSdk> sdk, Target target) : sdk_(std::move(sdk)), target_(target) {
    info_.backend = "fd";
    info_.sdk = sdk_->describe();
  }
  ~FdDevice() override { close(); }
  FdDevice(const FdDevice&) = delete;
  FdDevice& operator=(const FdDevice&) = delete;

  void open() override;
  void close() override;
  [[nodiscard]] HardwareInfo info() const override { return info_; }
  Calibration calibrate() override;
  HardwareReading read() override;
  void write(const Vec3& force, const Vec3& torque) override;
  void enable_force(bool on) override;

 private:
  [[nodiscard]] char id() const { return static_cast<char>(id_.load(std::memory_order_relaxed)); }
  [[noreturn]] void throw_open_error(int count) const;
  void reopen_loop();
  bool reopen();
  // Zeroes the output now (after an SDK error) and remembers the fault for the next reading.
  void fault(uint32_t bits);

  std::shared_ptr<const FdSdk> sdk_;
  Target target_;
  std::atomic<int> id_{-1};  // the SDK's device ID, -1 when closed
  Model model_ = kModels.back();
  HardwareInfo info_;
  bool drd_open_ = false;
  // Initialised (homed) as far as calibrate() found; calibrate() may run on a watcher thread.
  std::atomic<bool> homed_{false};
  bool force_on_ = false;  // dhdEnableForce(DHD_ON) done
  uint32_t pending_ = 0;   // servo thread: faults met in write()/enable_force(), for the next read()
  bool faulted_ = false;   // servo thread: the last reading carried a fault; write() sends zero
  int comm_errors_ = 0;    // servo thread: reads in a row with a communication error
  // The device lost: set by the servo thread, which then leaves the SDK alone; cleared by the reopen
  // thread once it has closed the dead handle and opened the device again (force off).
  std::atomic<bool> lost_{false};
  std::atomic<bool> stopping_{false};
  std::thread reopener_;
};

// Opens by index or serial, reads what the device is and switches its force off.
void FdDevice::open() {
  if (id_ >= 0 || reopener_.joinable()) return;
  const FdSdk& sdk = *sdk_;
  const int count = sdk.get_device_count();
  const int opened =
      target_.by_serial ? sdk.open_serial(target_.value) : sdk.open_id(static_cast<char>(target_.value));
  if (opened < 0) throw_open_error(count);
  id_ = opened;

  // What the device is.
  const int type = sdk.get_system_type(id());
  model_ = model_of(type);
  const char* name = sdk.get_system_name(id());
  info_.model = name != nullptr && *name != '\0' ? name : model_.name;
  if (model_.type == fd::kDeviceNone)
    spdlog::warn("fd: system type {} ({}) is not one cariesim knows: position and force only, at most {} N",
                 type, info_.model, model_.max_force);
  unsigned short serial = 0;
  info_.serial = sdk.get_serial_number(&serial, id()) >= 0 ? std::to_string(serial) : "";
  info_.dof_in = model_.dof_in;
  info_.dof_out = model_.dof_out;
  info_.buttons = model_.buttons;
  info_.max_force = model_.max_force;
  info_.continuous_force = model_.continuous_force;
  info_.max_stiffness = model_.max_stiffness;
  info_.max_torque = model_.dof_out == 6 ? model_.max_torque : 0.0;
  info_.workspace = Eigen::AlignedBox3d(Vec3(-model_.radius, -model_.radius, -model_.half_height),
                                        Vec3(model_.radius, model_.radius, model_.half_height));
  info_.rate_hz = 1000.0;
  // Force Dimension's frame (x toward the operator, y right, z up) in the operator frame (x right,
  // y away from the operator, z up): a quarter turn about z, x_fd -> -y, y_fd -> +x.
  info_.axes = Quat(Eigen::AngleAxisd(-std::numbers::pi / 2.0, Vec3::UnitZ()));
  info_.rest_orientation = Quat::Identity();

  // Force off until HapticDevice enables it after homing (a device may open with its force on).
  sdk.set_force_and_torque(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, id());
  sdk.enable_force(fd::kOff, id());
  force_on_ = false;
  homed_ = false;
  pending_ = 0;
  faulted_ = false;
  comm_errors_ = 0;
  lost_.store(false);
  stopping_.store(false);
  reopener_ = std::thread([this] { reopen_loop(); });
}

// The reopen thread: the servo thread only flags a lost device (it must not block); here the dead
// handle is closed and the device opened again (dhdClose, then dhdOpenID / dhdOpenSerial) until it
// answers. Until lost_ is cleared the servo thread makes no SDK call, so the two never share the SDK.
void FdDevice::reopen_loop() {
  bool reported = false;
  while (!stopping_.load()) {
    std::this_thread::sleep_for(lost_.load(std::memory_order_acquire) ? kReopenRetry : kReopenPoll);
    if (stopping_.load() || !lost_.load(std::memory_order_acquire)) continue;
    if (!reported) spdlog::warn("fd: {} lost; force off, reopening it when it answers", info_.model);
    reported = true;
    if (reopen()) {
      spdlog::info("fd: {} is back; force returns once the tool is out of contact", info_.model);
      reported = false;
      lost_.store(false, std::memory_order_release);
    }
  }
}

// Closes the dead handle, opens the device again (the same model), force off, homing checked.
bool FdDevice::reopen() {
  const FdSdk& sdk = *sdk_;
  const int old = id_.load(std::memory_order_relaxed);
  if (old >= 0) {
    if (drd_open_) sdk.drd_close(static_cast<char>(old));
    sdk.close(static_cast<char>(old));
    drd_open_ = false;
    id_.store(-2, std::memory_order_relaxed);  // closed, waiting for the device (not -1: not close()d)
  }
  const int opened =
      target_.by_serial ? sdk.open_serial(target_.value) : sdk.open_id(static_cast<char>(target_.value));
  if (opened < 0) return false;
  if (sdk.get_system_type(static_cast<char>(opened)) != model_.type) {
    sdk.close(static_cast<char>(opened));
    return false;  // another device in its place: not the one this run was set up for
  }
  id_.store(opened, std::memory_order_relaxed);
  sdk.set_force_and_torque(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, id());
  sdk.enable_force(fd::kOff, id());
  force_on_ = false;
  // Homing survives a USB reconnection on a powered device; a power cycle loses it: then the
  // readings say "calibration needed" and force stays off (docs/devices.md, "Force Dimension").
  bool homed = true;
  if (sdk.has_drd()) {
    drd_open_ = sdk.drd_open_id(id()) >= 0;
    homed = drd_open_ && sdk.drd_is_initialized(id());
    if (drd_open_ && model_.type != fd::kDeviceFalcon) sdk.drd_stop(false, id());
  }
  homed_ = homed;
  pending_ = homed ? 0u : static_cast<uint32_t>(kHardwareNotCalibrated);
  faulted_ = true;
  comm_errors_ = 0;
  return true;
}

// Why the SDK could not open the device, in words a lab can act on.
void FdDevice::throw_open_error(int count) const {
  const int code = sdk_->error_get_last();
  const std::string sdk = "SDK: " + sdk_->last_error();
  const std::string which = target_.describe();
  switch (code) {
    case fd::kErrorDeviceInUse:
      throw Error("fd: the device at " + which +
                  " is in use by another program (another cariesim, a Force Dimension demo, a ROS "
                  "driver): close it and try again (" +
                  sdk + ")");
    case fd::kErrorNoDriverFound:
      throw Error("fd: no permission to open the device at " + which +
                  " (its USB device is not accessible to this user): add the udev rule of docs/devices.md "
                  "(\"Force Dimension\": /etc/udev/rules.d/99-forcedimension.rules), then unplug and plug "
                  "it again (" +
                  sdk + ")");
    case fd::kErrorCom:
    case fd::kErrorTimeout:
      throw Error("fd: communication error with the device at " + which +
                  ": check its USB cable and power, then try again (" + sdk + ")");
    case fd::kErrorNoDeviceFound:
    case fd::kErrorInvalidIndex:
      if (count <= 0)
        throw Error("fd: no Force Dimension device found: check that it is plugged in and switched on; " +
                    std::string(kUdevHint) + " (" + sdk + ")");
      throw Error("fd: no device at " + which + " (" + std::to_string(count) + " attached, indices 0 to " +
                  std::to_string(count - 1) + ") (" + sdk + ")");
    default:
      throw Error("fd: cannot open the device at " + which + " (" + sdk + ")");
  }
}

// Force off, then the SDK's handles closed; harmless when never opened or already closed.
void FdDevice::close() {
  stopping_.store(true);
  if (reopener_.joinable()) reopener_.join();
  if (id_ == -2) id_ = -1;  // lost and not reopened: nothing left to close
  if (id_ < 0) return;
  const FdSdk& sdk = *sdk_;
  sdk.set_force_and_torque(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, id());
  sdk.enable_force(fd::kOff, id());
  if (drd_open_) sdk.drd_close(id());
  sdk.close(id());
  id_ = -1;
  drd_open_ = false;
  force_on_ = false;
  homed_ = false;
}

// Homing: the Falcon by hand (the operator is told how), the others by DRD's automatic
// initialisation, after which DRD's regulation is stopped so that the servo loop drives the device.
Calibration FdDevice::calibrate() {
  if (id_ < 0) return {Readiness::Failed, "fd: the device is not open"};
  const FdSdk& sdk = *sdk_;
  const bool falcon = model_.type == fd::kDeviceFalcon;
  if (!sdk.has_drd()) {
    // libdhd.so.3 alone cannot tell or make a device homed.
    homed_ = true;
    return {Readiness::Ready,
            "homing not checked: " + sdk.library.path() + " has no robotic SDK (DRD); " +
                (falcon ? "the Falcon must have been homed by hand since it was plugged in"
                        : "the device must have been initialised since it was switched on (Force "
                          "Dimension's autoinit tool), or load libdrd.so.3 to home it")};
  }
  if (!drd_open_) {
    if (sdk.drd_open_id(id()) < 0)
      return {Readiness::Failed,
              "fd: the robotic SDK cannot open the device (SDK: " + sdk.last_error() + ")"};
    drd_open_ = true;
  }
  if (sdk.drd_is_initialized(id())) {
    homed_ = true;
    if (!falcon) sdk.drd_stop(false, id());
    return {Readiness::Ready, falcon ? "Falcon homed" : "already homed"};
  }
  if (falcon)
    return {Readiness::NeedsOperator,
            "home the Falcon by hand: pull its grip all the way toward you, then push it all the way "
            "in; force stays off until it is homed"};

  // Robotic homing: the device moves by itself for a few seconds.
  spdlog::warn("fd: {} is not initialised: homing it robotically now; keep your hands off it", info_.model);
  if (sdk.drd_auto_init(id()) < 0) {
    const std::string why = sdk.last_error();
    sdk.drd_stop(false, id());
    return {Readiness::Failed, "fd: robotic homing failed (SDK: " + why +
                                   "); clear the workspace, check that nothing holds the handle, and retry"};
  }
  sdk.drd_stop(false, id());
  homed_ = true;
  return {Readiness::Ready, "homing (robotic): done, the device was not initialised and homed itself"};
}

// After an SDK error: zero output at once, in this cycle.
void FdDevice::fault(uint32_t bits) {
  pending_ |= bits;
  if (id_ >= 0) sdk_->set_force_and_torque(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, id());
}

// The device point (m -> mm), the orientation frame, velocities (m/s -> mm/s) and buttons; any
// error makes the reading invalid and zeroes the force in the same cycle.
HardwareReading FdDevice::read() {
  HardwareReading r;
  if (id_.load(std::memory_order_relaxed) < 0 || lost_.load(std::memory_order_acquire)) {
    r.faults = kHardwareLost;
    faulted_ = true;
    return r;
  }
  const FdSdk& sdk = *sdk_;
  double x = 0.0, y = 0.0, z = 0.0;
  bool ok = sdk.get_position(&x, &y, &z, id()) >= 0;
  r.pose.p = Vec3(x, y, z) * kMmPerM;
  if (ok && model_.dof_in == 6) {
    double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    ok = sdk.get_orientation_frame(m, id()) >= 0;
    Mat3 rotation;
    rotation << m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2];
    r.pose.q = Quat(rotation).normalized();
  }
  if (ok) {
    ok = sdk.get_linear_velocity(&x, &y, &z, id()) >= 0;
    r.velocity = Vec3(x, y, z) * kMmPerM;
  }
  if (ok && model_.dof_in == 6) {
    ok = sdk.get_angular_velocity(&x, &y, &z, id()) >= 0;
    r.angular_velocity = Vec3(x, y, z);
  }
  r.buttons = sdk.get_button_mask(id());
  if (!ok) {
    const uint32_t bits = faults_of(sdk.error_get_last());
    fault(bits);
    // Gone (no device) or a communication error that persists: the reopen thread takes over.
    comm_errors_ = (bits & kHardwareCommunication) != 0 ? comm_errors_ + 1 : 0;
    if ((bits & kHardwareLost) != 0 || comm_errors_ >= kLostAfter) {
      force_on_ = false;
      pending_ |= kHardwareLost;
      lost_.store(true, std::memory_order_release);
    }
  } else {
    comm_errors_ = 0;
  }
  if (!r.pose.finite() || !r.velocity.allFinite() || !r.angular_velocity.allFinite()) fault(kHardwareOther);
  r.faults = std::exchange(pending_, 0u);
  r.valid = r.faults == 0;
  faulted_ = !r.valid;
  return r;
}

// N and N·mm in the device frame -> N and N·m; zero after a faulty reading; the torque only on a
// device with active rotations, the gripper's force (zero) on a device with an active gripper.
void FdDevice::write(const Vec3& force, const Vec3& torque) {
  if (id_.load(std::memory_order_relaxed) < 0 || lost_.load(std::memory_order_acquire)) return;
  Vec3 f = force;
  Vec3 t = model_.dof_out == 6 ? Vec3(torque / kMmPerM) : Vec3::Zero();
  if (faulted_ || !f.allFinite() || !t.allFinite()) {
    f.setZero();
    t.setZero();
  }
  const FdSdk& sdk = *sdk_;
  const int rc = model_.gripper
                     ? sdk.set_force_torque_gripper(f.x(), f.y(), f.z(), t.x(), t.y(), t.z(), 0.0, id())
                     : sdk.set_force_and_torque(f.x(), f.y(), f.z(), t.x(), t.y(), t.z(), id());
  if (rc < 0) fault(faults_of(sdk.error_get_last()));
}

// dhdEnableForce; refused (force stays off) until the device is homed.
void FdDevice::enable_force(bool on) {
  if (id_.load(std::memory_order_relaxed) < 0 || lost_.load(std::memory_order_acquire)) return;
  if (on && !homed_) {
    pending_ |= kHardwareNotCalibrated;
    on = false;
  }
  if (on == force_on_) return;
  if (sdk_->enable_force(on ? fd::kOn : fd::kOff, id()) < 0) {
    fault(faults_of(sdk_->error_get_last()));
    if (on) return;
  }
  force_on_ = on;
}

}  // namespace

std::unique_ptr<HardwareDevice> make_fd_device(std::string_view index_or_serial) {
  const Target target = parse_target(index_or_serial);
  return std::make_unique<FdDevice>(load_sdk(), target);
}

// Each device the SDK sees, opened by index, described and closed.
HardwareSurvey survey_fd() {
  HardwareSurvey survey;
  survey.backend = "fd";
  survey.sdk = SharedLibrary::probe(kWhat, {"libdrd.so.3", "libdhd.so.3"}, kEnvVar);
  if (!survey.sdk.path) {
    survey.install = kInstall;
    return survey;
  }
  try {
    std::shared_ptr<const FdSdk> sdk = load_sdk(&survey.version);
    const int count = sdk->get_device_count();
    for (int i = 0; i < count && i <= kMaxIndex; ++i) {
      FdDevice device(sdk, Target{false, i});
      try {
        device.open();
        survey.devices.push_back(device.info());
        device.close();
      } catch (const Error& e) {
        survey.problem += (survey.problem.empty() ? "" : "; ") + std::string(e.what());
      }
    }
  } catch (const Error& e) {
    survey.problem = e.what();
  }
  return survey;
}

}  // namespace cariesim
