// The `touch` backend (docs/devices.md, "Touch"): OpenHaptics HD, loaded at run time, for the 3D Systems
// Touch, Touch X, Omni, Desktop and Phantom Premium (3-DoF and 6-DoF force). HD owns the servo thread:
// the device is its own DeviceClock, whose ticks are HD scheduler callbacks, each inside an HD frame.
//
// A device lost mid-run (unplugged, powered off) is reopened when it answers again. HD's scheduler
// keeps running meanwhile, so the servo loop keeps its clock: its readings are invalid (kHardwareLost)
// and it renders nothing. The servo callback only flags the loss (it must not block) and from then on
// leaves the device alone; a thread of the backend's own does what HD has the application thread do,
// hdDisableDevice on the dead handle and hdInitDevice until the device answers, and has the calibration
// checked on the scheduler thread (hdScheduleSynchronous, as calibrate() does) before it hands the
// device back to the servo callback by clearing an atomic flag.
#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <numbers>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "device/touch_api.hpp"

namespace cariesim {

namespace {

constexpr const char* kWhat = "OpenHaptics HD";
constexpr const char* kEnvVar = "CARIESIM_HD_LIBRARY";
constexpr const char* kInstall =
    "install 3D Systems' OpenHaptics for Linux and the device driver (Touch / Touch X: the "
    "TouchDriver package; see docs/devices.md, \"Touch\")";
constexpr int kOldestMajor = 3;  // the HD functions used here are those of OpenHaptics 3.0 and later
constexpr double kDefaultRateHz = 1000.0;
// Communication errors in this many readings in a row (0.1 s at 1 kHz) mean the device is gone.
constexpr int kLostAfter = 100;
// How often the reopen thread looks for a lost device, and tries to open it (or its calibration) again.
constexpr std::chrono::milliseconds kReopenPoll{50};
constexpr std::chrono::milliseconds kReopenRetry{250};

// The library names the dynamic loader is asked for, newest first after the unversioned link.
const std::vector<std::string>& library_names() {
  static const std::vector<std::string> names{"libHD.so", "libHD.so.3.4", "libHD.so.3.0"};
  return names;
}

// One HD error code: its name, what it means to the operator and the fault bit it sets.
struct HdError {
  hd::HDerror code;
  const char* name;
  const char* words;
  uint32_t fault;
};

constexpr std::array<HdError, 21> kHdErrors = {{
    {hd::kInvalidEnum, "HD_INVALID_ENUM", "the SDK does not know a parameter cariesim asked for",
     kHardwareOther},
    {hd::kInvalidValue, "HD_INVALID_VALUE", "a value out of the SDK's range", kHardwareOther},
    {hd::kInvalidOperation, "HD_INVALID_OPERATION", "an operation the SDK refused in this state",
     kHardwareOther},
    {hd::kInvalidInputType, "HD_INVALID_INPUT_TYPE", "a parameter of the wrong type", kHardwareOther},
    {hd::kBadHandle, "HD_BAD_HANDLE", "the device handle is no longer valid", kHardwareLost},
    {hd::kWarmMotors, "HD_WARM_MOTORS", "the motors are too warm: let the device cool down",
     kHardwareOverheat},
    {hd::kExceededMaxForce, "HD_EXCEEDED_MAX_FORCE", "a force above the device's maximum",
     kHardwareForceExceeded},
    {hd::kExceededMaxForceImpulse, "HD_EXCEEDED_MAX_FORCE_IMPULSE", "a force step too large",
     kHardwareForceExceeded},
    {hd::kExceededMaxVelocity, "HD_EXCEEDED_MAX_VELOCITY", "the stylus moved faster than the device allows",
     kHardwareVelocityExceeded},
    {hd::kForceError, "HD_FORCE_ERROR", "the device could not render the force", kHardwareForceExceeded},
    {hd::kDeviceFault, "HD_DEVICE_FAULT", "the device reported a fault (is it plugged in and powered?)",
     kHardwareLost},
    {hd::kDeviceAlreadyInitiated, "HD_DEVICE_ALREADY_INITIATED", "the device is already open in this program",
     kHardwareOther},
    {hd::kCommError, "HD_COMM_ERROR", "communication with the device failed (cable, USB, power)",
     kHardwareCommunication},
    {hd::kCommConfigError, "HD_COMM_CONFIG_ERROR",
     "the device's configuration is missing or wrong (run the vendor's Touch Setup)", kHardwareCommunication},
    {hd::kTimerError, "HD_TIMER_ERROR", "the servo timer failed", kHardwareCommunication},
    {hd::kIllegalBegin, "HD_ILLEGAL_BEGIN", "a frame began inside another", kHardwareOther},
    {hd::kIllegalEnd, "HD_ILLEGAL_END", "a frame ended that had not begun", kHardwareOther},
    {hd::kFrameError, "HD_FRAME_ERROR", "a frame error", kHardwareOther},
    {hd::kInvalidPriority, "HD_INVALID_PRIORITY", "a scheduler priority out of range", kHardwareOther},
    {hd::kSchedulerFull, "HD_SCHEDULER_FULL", "the scheduler has no room for another callback",
     kHardwareOther},
    {hd::kInvalidLicense, "HD_INVALID_LICENSE", "OpenHaptics' licence is missing or invalid", kHardwareOther},
}};

// The table's entry for a code, or null.
const HdError* find_error(hd::HDerror code) {
  for (const HdError& e : kHdErrors)
    if (e.code == code) return &e;
  return nullptr;
}

// "HD_WARM_MOTORS (0x0200, device code 0): the motors are too warm: ..." for an error.
std::string hd_error_text(const hd::HDErrorInfo& e) {
  char code[16];
  std::snprintf(code, sizeof(code), "0x%04X", e.errorCode);
  const HdError* known = find_error(e.errorCode);
  return std::string(known != nullptr ? known->name : "unknown HD error") + " (" + std::string(code) +
         ", device code " + std::to_string(e.internalErrorCode) +
         "): " + (known != nullptr ? known->words : "see the HD manual");
}

// Why hdInitDevice failed, in words: busy and no permission are told apart by the device's own
// code (the driver's errno), as the stand-in and docs/devices.md describe.
std::string open_error_text(const hd::HDErrorInfo& e) {
  const std::string base = hd_error_text(e);
  const int internal = e.internalErrorCode;
  if (e.errorCode == hd::kDeviceAlreadyInitiated)
    return "device busy: it is already open in this program; " + base;
  if (internal == EBUSY)
    return "device busy: another program holds it (close Touch Setup/Diagnostic); " + base;
  if (internal == EACCES || internal == EPERM)
    return "no permission to open the device: add the udev rule of docs/devices.md (\"Touch\") and "
           "re-plug it; " +
           base;
  if (e.errorCode == hd::kDeviceFault || e.errorCode == hd::kCommError)
    return "no device answered: check that it is plugged in, powered and configured; " + base;
  return base;
}

// Major and minor of a version string such as "3.4.0"; {0, 0} when it has none.
std::pair<int, int> parse_version(std::string_view text) {
  int major = 0;
  int minor = 0;
  const char* p = text.data();
  const char* end = p + text.size();
  auto [after_major, ec] = std::from_chars(p, end, major);
  if (ec != std::errc()) return {0, 0};
  if (after_major < end && *after_major == '.') std::from_chars(after_major + 1, end, minor);
  return {major, minor};
}

// The HD functions, each resolved by name when the library loads (a missing one is named).
struct HdApi {
  explicit HdApi(const SharedLibrary& lib)
      : init_device(lib.symbol<hd::InitDeviceFn>("hdInitDevice")),
        disable_device(lib.symbol<hd::DisableDeviceFn>("hdDisableDevice")),
        make_current_device(lib.symbol<hd::MakeCurrentDeviceFn>("hdMakeCurrentDevice")),
        begin_frame(lib.symbol<hd::FrameFn>("hdBeginFrame")),
        end_frame(lib.symbol<hd::FrameFn>("hdEndFrame")),
        get_error(lib.symbol<hd::GetErrorFn>("hdGetError")),
        enable(lib.symbol<hd::CapabilityFn>("hdEnable")),
        disable(lib.symbol<hd::CapabilityFn>("hdDisable")),
        get_integerv(lib.symbol<hd::GetIntegervFn>("hdGetIntegerv")),
        get_doublev(lib.symbol<hd::GetDoublevFn>("hdGetDoublev")),
        get_string(lib.symbol<hd::GetStringFn>("hdGetString")),
        set_doublev(lib.symbol<hd::SetDoublevFn>("hdSetDoublev")),
        check_calibration(lib.symbol<hd::CheckCalibrationFn>("hdCheckCalibration")),
        update_calibration(lib.symbol<hd::UpdateCalibrationFn>("hdUpdateCalibration")),
        start_scheduler(lib.symbol<hd::SchedulerFn>("hdStartScheduler")),
        stop_scheduler(lib.symbol<hd::SchedulerFn>("hdStopScheduler")),
        schedule_asynchronous(lib.symbol<hd::ScheduleFn>("hdScheduleAsynchronous")),
        schedule_synchronous(lib.symbol<hd::ScheduleSynchronousFn>("hdScheduleSynchronous")),
        unschedule(lib.symbol<hd::UnscheduleFn>("hdUnschedule")) {}
  hd::InitDeviceFn init_device;
  hd::DisableDeviceFn disable_device;
  hd::MakeCurrentDeviceFn make_current_device;
  hd::FrameFn begin_frame;
  hd::FrameFn end_frame;
  hd::GetErrorFn get_error;
  hd::CapabilityFn enable;
  hd::CapabilityFn disable;
  hd::GetIntegervFn get_integerv;
  hd::GetDoublevFn get_doublev;
  hd::GetStringFn get_string;
  hd::SetDoublevFn set_doublev;
  hd::CheckCalibrationFn check_calibration;
  hd::UpdateCalibrationFn update_calibration;
  hd::SchedulerFn start_scheduler;
  hd::SchedulerFn stop_scheduler;
  hd::ScheduleFn schedule_asynchronous;
  hd::ScheduleSynchronousFn schedule_synchronous;
  hd::UnscheduleFn unschedule;
};

// HD's axes (x right, y up, z toward the user) in the operator frame (x right, y away, z up): a
// quarter turn about x.
Quat hd_axes() { return Quat(Eigen::AngleAxisd(std::numbers::pi / 2.0, Vec3::UnitX())); }

// The stylus standing tip down in its inkwell: the stylus axis (HD's end-effector +z, tip to back)
// points up (HD +y).
Quat hd_rest_orientation() { return Quat(Eigen::AngleAxisd(-std::numbers::pi / 2.0, Vec3::UnitX())); }

// The calibration style to use of those the device supports (HD_CALIBRATION_STYLE bits): automatic
// first, then the inkwell, then an encoder reset, as the vendor's calibration example prefers.
hd::HDenum pick_style(hd::HDint styles) {
  if ((styles & hd::kCalibrationAuto) != 0) return hd::kCalibrationAuto;
  if ((styles & hd::kCalibrationInkwell) != 0) return hd::kCalibrationInkwell;
  if ((styles & hd::kCalibrationEncoderReset) != 0) return hd::kCalibrationEncoderReset;
  return 0;
}

// What the operator must do for a calibration style that needs manual input.
std::string operator_step(hd::HDenum style) {
  if (style == hd::kCalibrationInkwell) return "put the stylus in the inkwell";
  if (style == hd::kCalibrationEncoderReset)
    return "hold the arm in its reset (neutral) position, as the device's manual shows";
  return "move the stylus through the whole workspace so the device calibrates itself";
}

// True on HD's scheduler thread while the servo callback runs (inside its frame).
thread_local bool in_servo_frame = false;

// An OpenHaptics device and, since HD runs the servo thread, its DeviceClock.
class TouchDevice final : public HardwareDevice, public DeviceClock {
 public:
  explicit TouchDevice(std::string name)
      : name_(std::move(name)),
        library_(SharedLibrary::open(kWhat, library_names(), kEnvVar, kInstall)),
        api_(library_) {}
  ~TouchDevice() override { close(); }
  TouchDevice(const TouchDevice&) = delete;
  TouchDevice& operator=(const TouchDevice&) = delete;

  void open() override;
  void close() override;
  [[nodiscard]] HardwareInfo info() const override { return info_; }
  Calibration calibrate() override;
  HardwareReading read() override;
  void write(const Vec3& force, const Vec3& torque) override;
  void enable_force(bool on) override;
  DeviceClock* clock() override { return this; }

  [[nodiscard]] double rate_hz() const override { return info_.rate_hz; }
  void start_clock(Tick tick, void* context) override;
  void stop_clock() override;

  [[nodiscard]] const std::string& version() const { return version_; }

 private:
  static hd::HDCallbackCode servo_callback(void* self);
  static hd::HDCallbackCode calibration_callback(void* self);
  hd::HDErrorInfo first_error();
  void collect_faults();
  hd::HHD init(const char* name, hd::HDErrorInfo& error);
  void read_info();
  void run_calibration();
  Calibration check_calibration();
  void lose();
  void reopen_loop();
  bool reopen();

  std::string name_;
  SharedLibrary library_;
  HdApi api_;
  hd::HHD handle_ = hd::kInvalidHandle;
  bool open_ = false;
  std::string version_;
  HardwareInfo info_;
  hd::HDenum style_ = 0;
  Calibration calibration_;  // written by run_calibration (control thread or the scheduler's)
  std::atomic<bool> calibrated_{false};
  // The clock (control threads; clock_mutex_ orders starting and stopping it with calibrate()).
  std::mutex clock_mutex_;
  std::atomic<bool> running_{false};
  hd::HDSchedulerHandle scheduled_ = 0;
  Tick tick_ = nullptr;
  void* context_ = nullptr;
  std::atomic<bool> stopping_{false};
  // The servo thread's (HD's scheduler thread while the clock runs).
  uint32_t pending_faults_ = 0;  // HardwareFault bits of errors since the last read
  uint32_t cycle_faults_ = 0;    // the faults of this cycle's read: its write renders no force
  bool force_on_ = false;
  int comm_errors_ = 0;            // readings in a row with a communication error
  bool lose_after_frame_ = false;  // lost inside the servo callback: flagged once its frame ends
  // The device lost: set by the servo thread, which then makes no HD call on it; cleared by the
  // reopen thread once the device is open again (force off). awaiting_calibration_: reopened but
  // not calibrated yet (the readings say so, force stays off).
  std::atomic<bool> lost_{false};
  std::atomic<bool> awaiting_calibration_{false};
  std::atomic<bool> stop_reopen_{false};
  std::thread reopener_;
};

// The first error on HD's error stack; the rest are drained (open and close, control thread).
hd::HDErrorInfo TouchDevice::first_error() {
  hd::HDErrorInfo first{hd::kSuccess, 0, 0};
  for (int i = 0; i < 32; ++i) {
    const hd::HDErrorInfo e = api_.get_error();
    if (e.errorCode == hd::kSuccess) break;
    if (first.errorCode == hd::kSuccess) first = e;
  }
  return first;
}

// Drains HD's error stack into fault bits for the next reading; no allocation (servo thread).
void TouchDevice::collect_faults() {
  for (int i = 0; i < 32; ++i) {
    const hd::HDErrorInfo e = api_.get_error();
    if (e.errorCode == hd::kSuccess) return;
    const HdError* known = find_error(e.errorCode);
    pending_faults_ |= known != nullptr ? known->fault : kHardwareOther;
  }
}

// hdInitDevice of one configuration (null: HD_DEFAULT_DEVICE); the error, if any, in `error`.
hd::HHD TouchDevice::init(const char* name, hd::HDErrorInfo& error) {
  const hd::HHD handle = api_.init_device(name);
  error = first_error();
  if (error.errorCode == hd::kSuccess && handle == hd::kInvalidHandle) error = {hd::kBadHandle, 0, handle};
  return handle;
}

// Opens by name, else the default device (it is the default that fails on some installs, the
// name on others); checks the SDK's version; reads what the device is; force off until enabled.
void TouchDevice::open() {
  if (open_) return;
  hd::HDErrorInfo error{};
  const std::string which = name_.empty() ? "the default device" : "device '" + name_ + "'";
  hd::HHD handle = init(name_.empty() ? nullptr : name_.c_str(), error);
  if (error.errorCode != hd::kSuccess && !name_.empty()) {
    const std::string named_failure = open_error_text(error);
    handle = init(nullptr, error);
    if (error.errorCode != hd::kSuccess)
      throw Error("touch: cannot open " + which + " (" + named_failure + ") nor the default device (" +
                  open_error_text(error) + ")");
    spdlog::warn("touch: {} did not open ({}); using the default device", which, named_failure);
  } else if (error.errorCode != hd::kSuccess) {
    throw Error("touch: cannot open " + which + ": " + open_error_text(error));
  }
  handle_ = handle;
  api_.make_current_device(handle_);
  const char* version = api_.get_string(hd::kVersion);
  version_ = version != nullptr ? version : "";
  (void)first_error();
  const auto [major, minor] = parse_version(version_);
  if (major < kOldestMajor) {
    api_.disable_device(handle_);
    (void)first_error();
    handle_ = hd::kInvalidHandle;
    throw Error("touch: " + library_.path() + " is OpenHaptics HD " +
                (version_.empty() ? std::string("of unknown version") : version_) + ", older than " +
                std::to_string(kOldestMajor) + ".0, the oldest cariesim supports; " + kInstall);
  }
  read_info();
  api_.disable(hd::kForceOutput);
  (void)first_error();
  force_on_ = false;
  pending_faults_ = 0;
  comm_errors_ = 0;
  lose_after_frame_ = false;
  lost_.store(false);
  awaiting_calibration_.store(false);
  stop_reopen_.store(false);
  open_ = true;
  reopener_ = std::thread([this] { reopen_loop(); });
}

// The reopen thread: waits for the servo thread to flag the device lost, then reopens it; once
// reopened but not calibrated, checks the calibration again until it is.
void TouchDevice::reopen_loop() {
  bool reported = false;
  while (!stop_reopen_.load()) {
    const bool lost = lost_.load(std::memory_order_acquire);
    std::this_thread::sleep_for(lost || awaiting_calibration_.load() ? kReopenRetry : kReopenPoll);
    if (stop_reopen_.load()) break;
    if (lost_.load(std::memory_order_acquire)) {
      if (!reported) spdlog::warn("touch: {} lost; force off, reopening it when it answers", info_.model);
      reported = true;
      if (!reopen()) continue;
      reported = false;
      spdlog::info("touch: {} is back", info_.model);
      lost_.store(false, std::memory_order_release);
    } else if (awaiting_calibration_.load() && check_calibration().readiness == Readiness::Ready) {
      awaiting_calibration_.store(false);
    }
  }
}

// hdDisableDevice on the dead handle, then hdInitDevice (by name, else the default device) of the
// same model; force off; the calibration checked. False while the device does not answer.
bool TouchDevice::reopen() {
  if (handle_ != hd::kInvalidHandle) {
    api_.disable_device(handle_);
    (void)first_error();
    handle_ = hd::kInvalidHandle;
  }
  hd::HDErrorInfo error{};
  hd::HHD handle = init(name_.empty() ? nullptr : name_.c_str(), error);
  if (error.errorCode != hd::kSuccess && !name_.empty()) handle = init(nullptr, error);
  if (error.errorCode != hd::kSuccess) return false;
  api_.make_current_device(handle);
  api_.disable(hd::kForceOutput);
  const char* model = api_.get_string(hd::kDeviceModelType);
  (void)first_error();
  if (model == nullptr || (*model != '\0' && info_.model != model)) {
    api_.disable_device(handle);  // another device in its place: not the one this run was set up for
    (void)first_error();
    return false;
  }
  handle_ = handle;
  const Calibration calibration = check_calibration();
  awaiting_calibration_.store(calibration.readiness != Readiness::Ready);
  return true;
}

// calibrate()'s check from the reopen thread: on the scheduler thread while the clock runs.
Calibration TouchDevice::check_calibration() {
  const std::lock_guard lock(clock_mutex_);
  if (running_.load())
    api_.schedule_synchronous(&TouchDevice::calibration_callback, this, hd::kDefaultSchedulerPriority);
  else
    run_calibration();
  calibrated_ = calibration_.readiness == Readiness::Ready;
  return calibration_;
}

// The servo thread's side of a loss: no force from now on, and no HD call on the device.
void TouchDevice::lose() {
  force_on_ = false;
  comm_errors_ = 0;
  if (in_servo_frame)
    lose_after_frame_ = true;  // the callback ends its frame first
  else
    lost_.store(true, std::memory_order_release);
}

// The device's identity, degrees of freedom, limits (HD: N, N/mm, mN·m = N·mm) and workspace (mm).
void TouchDevice::read_info() {
  HardwareInfo info;
  info.backend = "touch";
  const char* model = api_.get_string(hd::kDeviceModelType);
  info.model = model != nullptr && *model != '\0' ? model : "OpenHaptics device";
  const char* serial = api_.get_string(hd::kDeviceSerialNumber);
  info.serial = serial != nullptr ? serial : "";
  info.sdk = library_.path() + " " + version_;
  hd::HDint dof_in = 6;
  hd::HDint dof_out = 3;
  api_.get_integerv(hd::kInputDof, &dof_in);
  api_.get_integerv(hd::kOutputDof, &dof_out);
  info.dof_in = dof_in >= 6 ? 6 : 3;
  info.dof_out = dof_out >= 6 ? 6 : 3;
  info.buttons = 2;  // HD tells no count: the Touch and Omni have two stylus buttons
  hd::HDdouble value = 0.0;
  api_.get_doublev(hd::kNominalMaxForce, &value);
  info.max_force = value;
  value = 0.0;
  api_.get_doublev(hd::kNominalMaxContinuousForce, &value);
  info.continuous_force = value;
  value = 0.0;
  api_.get_doublev(hd::kNominalMaxStiffness, &value);
  info.max_stiffness = value;
  if (info.dof_out == 6) {
    value = 0.0;
    api_.get_doublev(hd::kNominalMaxTorqueForce, &value);
    info.max_torque = value;  // mN·m is N·mm
  }
  std::array<hd::HDdouble, 6> box{};
  api_.get_doublev(hd::kUsableWorkspaceDimensions, box.data());
  info.workspace = Eigen::AlignedBox3d(Vec3(box[0], box[1], box[2]), Vec3(box[3], box[4], box[5]));
  hd::HDint rate = 0;
  api_.get_integerv(hd::kUpdateRate, &rate);
  info.rate_hz = rate > 0 ? rate : kDefaultRateHz;
  hd::HDint styles = 0;
  api_.get_integerv(hd::kCalibrationStyle, &styles);
  style_ = pick_style(styles);
  info.axes = hd_axes();
  info.rest_orientation = hd_rest_orientation();
  const hd::HDErrorInfo error = first_error();
  if (error.errorCode != hd::kSuccess) {
    api_.disable_device(handle_);
    (void)first_error();
    handle_ = hd::kInvalidHandle;
    throw Error("touch: reading what the device is failed: " + hd_error_text(error));
  }
  bool finite = std::isfinite(info.max_force) && std::isfinite(info.continuous_force) &&
                std::isfinite(info.max_stiffness) && std::isfinite(info.max_torque);
  for (double b : box) finite = finite && std::isfinite(b);
  if (!finite || info.max_force < 0.0 || info.continuous_force < 0.0 || info.max_stiffness < 0.0 ||
      info.max_torque < 0.0) {
    api_.disable_device(handle_);
    (void)first_error();
    handle_ = hd::kInvalidHandle;
    throw Error("touch: the device reports a non-finite or negative limit (HD_NOMINAL_MAX_FORCE " +
                std::to_string(info.max_force) + " N, HD_NOMINAL_MAX_CONTINUOUS_FORCE " +
                std::to_string(info.continuous_force) + " N, HD_NOMINAL_MAX_STIFFNESS " +
                std::to_string(info.max_stiffness) + " N/mm)");
  }
  info_ = info;
}

// Switches the force off, stops the scheduler and releases the device.
void TouchDevice::close() {
  stop_reopen_.store(true);
  if (reopener_.joinable()) reopener_.join();
  if (!open_) return;
  stop_clock();
  if (handle_ != hd::kInvalidHandle) {  // invalid: lost, and not reopened
    api_.make_current_device(handle_);
    api_.disable(hd::kForceOutput);
    api_.disable_device(handle_);
  }
  (void)first_error();
  handle_ = hd::kInvalidHandle;
  force_on_ = false;
  calibrated_ = false;
  open_ = false;
}

// Checks the calibration inside a frame and updates it when HD can by itself (hdUpdateCalibration);
// asks the operator otherwise. Runs in a scheduler callback while the clock runs (HD's functions are
// the scheduler thread's then), directly otherwise.
Calibration TouchDevice::calibrate() {
  if (!open_) return {Readiness::Failed, "touch: the device is not open"};
  const std::lock_guard lock(clock_mutex_);
  if (running_.load())
    api_.schedule_synchronous(&TouchDevice::calibration_callback, this, hd::kDefaultSchedulerPriority);
  else
    run_calibration();
  calibrated_ = calibration_.readiness == Readiness::Ready;
  return calibration_;
}

hd::HDCallbackCode TouchDevice::calibration_callback(void* self) {
  static_cast<TouchDevice*>(self)->run_calibration();
  return hd::kCallbackDone;
}

// One check (and update) of the calibration; the result in calibration_.
void TouchDevice::run_calibration() {
  api_.begin_frame(handle_);
  hd::HDenum status = api_.check_calibration();
  bool updated = false;
  if (status == hd::kCalibrationNeedsUpdate && style_ != 0) {
    api_.update_calibration(style_);
    status = api_.check_calibration();
    updated = true;
  }
  api_.end_frame(handle_);
  const hd::HDErrorInfo error = first_error();
  const char* style_name = style_ == hd::kCalibrationAuto      ? "automatic"
                           : style_ == hd::kCalibrationInkwell ? "inkwell"
                                                               : "encoder reset";
  if (error.errorCode != hd::kSuccess) {
    calibration_ = {Readiness::Failed, "touch: calibration failed: " + hd_error_text(error)};
  } else if (status == hd::kCalibrationOk) {
    calibration_ = {Readiness::Ready,
                    updated ? std::string("calibration updated (") + style_name + ")" : "calibrated"};
  } else if (status == hd::kCalibrationNeedsManualInput || status == hd::kCalibrationNeedsUpdate) {
    calibration_ = {Readiness::NeedsOperator, "touch: calibration needed: " + operator_step(style_)};
  } else {
    calibration_ = {Readiness::Failed,
                    "touch: hdCheckCalibration answered an unknown status " + std::to_string(status)};
  }
}

// One reading inside the current frame: HD_CURRENT_TRANSFORM (column-major 4x4, mm),
// HD_CURRENT_VELOCITY (mm/s), HD_CURRENT_ANGULAR_VELOCITY (rad/s), HD_CURRENT_BUTTONS; the errors
// since the last reading become its faults.
HardwareReading TouchDevice::read() {
  HardwareReading reading;
  if (!open_ || lost_.load(std::memory_order_acquire) || lose_after_frame_) {
    reading.faults = kHardwareLost;
    cycle_faults_ = reading.faults;
    return reading;
  }
  std::array<hd::HDdouble, 16> m{};
  std::array<hd::HDdouble, 3> v{};
  std::array<hd::HDdouble, 3> w{};
  hd::HDint buttons = 0;
  api_.get_doublev(hd::kCurrentTransform, m.data());
  collect_faults();
  api_.get_doublev(hd::kCurrentVelocity, v.data());
  collect_faults();
  if (info_.dof_in == 6) {
    api_.get_doublev(hd::kCurrentAngularVelocity, w.data());
    collect_faults();
  }
  api_.get_integerv(hd::kCurrentButtons, &buttons);
  collect_faults();
  reading.pose.p = Vec3(m[12], m[13], m[14]);
  if (info_.dof_in == 6) {
    Mat3 r;
    r << m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10];
    reading.pose.q = Quat(r);
    if (reading.pose.q.coeffs().allFinite() && reading.pose.q.norm() > 0.5) reading.pose.q.normalize();
    reading.angular_velocity = Vec3(w[0], w[1], w[2]);
  }
  reading.velocity = Vec3(v[0], v[1], v[2]);
  reading.buttons = static_cast<uint32_t>(buttons) & 0xFu;
  if (!reading.pose.finite() || !reading.velocity.allFinite() || !reading.angular_velocity.allFinite())
    pending_faults_ |= kHardwareOther;
  if (awaiting_calibration_.load(std::memory_order_relaxed)) pending_faults_ |= kHardwareNotCalibrated;
  // Gone (HD_DEVICE_FAULT, HD_BAD_HANDLE) or a communication error that persists: the reopen
  // thread takes over.
  comm_errors_ = (pending_faults_ & kHardwareCommunication) != 0 ? comm_errors_ + 1 : 0;
  if ((pending_faults_ & kHardwareLost) != 0 || comm_errors_ >= kLostAfter) {
    pending_faults_ |= kHardwareLost;
    lose();
  }
  reading.faults = pending_faults_;
  reading.valid = reading.faults == 0;
  cycle_faults_ = reading.faults;
  pending_faults_ = 0;
  return reading;
}

// HD_CURRENT_FORCE in N and, on a 6-DoF-force device, HD_CURRENT_TORQUE in mN·m (= N·mm), both in
// HD's frame; a cycle whose reading carried a fault, or a non-finite wrench, renders zero. HD takes
// forces inside a frame: the servo callback's, or (the clock stopped, e.g. a last zero wrench at
// stop) one of its own; while the clock runs, only the servo callback writes.
void TouchDevice::write(const Vec3& force, const Vec3& torque) {
  if (!open_ || lost_.load(std::memory_order_acquire)) return;
  if (!in_servo_frame) {
    if (running_.load()) return;
    api_.begin_frame(handle_);
    in_servo_frame = true;
    write(force, torque);
    in_servo_frame = false;
    api_.end_frame(handle_);
    collect_faults();
    return;
  }
  const bool safe = cycle_faults_ == 0 && force.allFinite() && torque.allFinite();
  const std::array<hd::HDdouble, 3> f = safe ? std::array<hd::HDdouble, 3>{force.x(), force.y(), force.z()}
                                             : std::array<hd::HDdouble, 3>{0.0, 0.0, 0.0};
  api_.set_doublev(hd::kCurrentForce, f.data());
  collect_faults();
  if (info_.dof_out == 6) {
    const std::array<hd::HDdouble, 3> t =
        safe ? std::array<hd::HDdouble, 3>{torque.x(), torque.y(), torque.z()}
             : std::array<hd::HDdouble, 3>{0.0, 0.0, 0.0};
    api_.set_doublev(hd::kCurrentTorque, t.data());
    collect_faults();
  }
}

// hdEnable / hdDisable(HD_FORCE_OUTPUT); never on before a calibration that came out Ready.
void TouchDevice::enable_force(bool on) {
  if (!open_ || lost_.load(std::memory_order_acquire) || lose_after_frame_) return;
  const bool want = on && calibrated_.load();
  if (want == force_on_) return;
  if (want)
    api_.enable(hd::kForceOutput);
  else
    api_.disable(hd::kForceOutput);
  collect_faults();
  force_on_ = want;
}

// One servo cycle inside one HD frame, on HD's scheduler thread.
hd::HDCallbackCode TouchDevice::servo_callback(void* self) {
  auto* device = static_cast<TouchDevice*>(self);
  if (device->stopping_.load(std::memory_order_acquire)) return hd::kCallbackDone;
  // A lost device is the reopen thread's: the cycle runs (its reading says lost) without a frame.
  const bool lost = device->lost_.load(std::memory_order_acquire);
  if (!lost) {
    device->api_.begin_frame(device->handle_);
    device->collect_faults();
  }
  in_servo_frame = true;
  device->tick_(device->context_);
  in_servo_frame = false;
  if (!lost) {
    device->api_.end_frame(device->handle_);
    device->collect_faults();
  }
  if (device->lose_after_frame_) {
    device->lose_after_frame_ = false;
    device->lost_.store(true, std::memory_order_release);
  }
  return hd::kCallbackContinue;
}

// Schedules the servo callback at the highest priority and starts HD's scheduler.
void TouchDevice::start_clock(Tick tick, void* context) {
  if (!open_) throw Error("touch: start_clock on a device that is not open");
  const std::lock_guard lock(clock_mutex_);
  if (running_.load()) return;
  tick_ = tick;
  context_ = context;
  stopping_.store(false, std::memory_order_release);
  scheduled_ = api_.schedule_asynchronous(&TouchDevice::servo_callback, this, hd::kMaxSchedulerPriority);
  hd::HDErrorInfo error = first_error();
  if (error.errorCode != hd::kSuccess)
    throw Error("touch: hdScheduleAsynchronous refused the servo callback: " + hd_error_text(error));
  api_.start_scheduler();
  error = first_error();
  if (error.errorCode != hd::kSuccess) {
    api_.unschedule(scheduled_);
    (void)first_error();
    throw Error("touch: the HD scheduler did not start: " + hd_error_text(error));
  }
  running_ = true;
}

// Stops the scheduler (hdStopScheduler returns once its thread has finished its last tick) and
// removes the callback.
void TouchDevice::stop_clock() {
  const std::lock_guard lock(clock_mutex_);
  if (!running_.load()) return;
  stopping_.store(true, std::memory_order_release);
  api_.stop_scheduler();
  api_.unschedule(scheduled_);
  (void)first_error();
  running_ = false;
}

}  // namespace

std::unique_ptr<HardwareDevice> make_touch_device(std::string_view name) {
  return std::make_unique<TouchDevice>(std::string(name));
}

// The library, and the default device opened and closed again (HD lists no devices).
HardwareSurvey survey_touch() {
  HardwareSurvey survey;
  survey.backend = "touch";
  survey.sdk = SharedLibrary::probe(kWhat, library_names(), kEnvVar);
  survey.install = kInstall;
  if (!survey.sdk.path) {
    survey.problem = survey.sdk.describe();
    return survey;
  }
  try {
    TouchDevice device("");
    device.open();
    survey.version = device.version();
    survey.devices.push_back(device.info());
    device.close();
  } catch (const Error& e) {
    survey.problem = e.what();
  }
  return survey;
}

}  // namespace cariesim
