// A stand-in for OpenHaptics' libHD.so (test code, built as libHD.so in the build tree only, never
// installed): the documented HD functions the `touch` backend uses, over one simulated stylus with
// mass and damping pushed by a spring "hand", in HD's units (mm, N, mN·m) and frame (x right, y up,
// z toward the user). It keeps HD's rules: its own scheduler thread at the set rate (hdSetSchedulerRate,
// 1000 Hz by default) runs the scheduled callbacks, highest priority first; forces are written inside
// hdBeginFrame/hdEndFrame and sent at the outermost hdEndFrame when HD_FORCE_OUTPUT is enabled;
// errors go on a stack that hdGetError pops; calibration goes through hdCheckCalibration and
// hdUpdateCalibration with the device's calibration style.
//
// Test-only functions (standin_hd_*) move the hand, set buttons, inject errors, configure the device
// and read back the force in HD's units. CARIESIM_STANDIN_HD=circle makes the hand trace a circle (and
// "buttons" in it presses buttons 0 and 1 in turn) (20 mm radius, 0.5 Hz, in the x-z plane) so that `cariesim
// servo --device touch` moves; "unplug-at-Ts" in it pulls the cable T s of scheduler time after the
// device opened and "replug-at-Ts" plugs it back (standin_hd_unplug does the same from a test).
// Unplugged, every frame raises HD_COMM_ERROR and the motors render nothing; the handle stays dead
// until hdDisableDevice, and hdInitDevice finds no device (HD_DEVICE_FAULT) until it is plugged back.
// CARIESIM_STANDIN_HD_BUTTONS="T:MASK,T:MASK,..." scripts the buttons: from T
// seconds after hdStartScheduler on, the pressed buttons are MASK (bit i = button i), e.g. "0.5:1,1.5:0"
// holds button 0 from 0.5 s to 1.5 s.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "device/touch_api.hpp"

using namespace cariesim::hd;  // NOLINT: the stand-in speaks HD's names only

namespace {

// What the simulated device is (standin_hd_configure changes it).
struct Config {
  std::string name = "Default Device";  // the configuration hdInitDevice accepts by name
  std::string model = "Touch";
  std::string serial = "220-00042";
  std::string version = "3.4.0";
  HDint dof_in = 6;
  HDint dof_out = 3;
  HDint calibration_styles = kCalibrationInkwell;
  double max_force = 3.3;                                         // N
  double continuous_force = 0.88;                                 // N
  double max_stiffness = 1.26;                                    // N/mm
  double max_torque = 0.0;                                        // mN·m
  double workspace[6] = {-80.0, -60.0, -35.0, 80.0, 60.0, 35.0};  // mm
  bool default_fails = false;     // hdInitDevice(HD_DEFAULT_DEVICE) fails with HD_DEVICE_FAULT
  HDerror open_error = kSuccess;  // every hdInitDevice fails with this
  int open_internal = 0;
};

struct Scheduled {
  HDSchedulerHandle handle;
  HDSchedulerCallback callback;
  void* data;
  HDushort priority;
};

struct Synchronous {
  HDSchedulerCallback callback;
  void* data;
  bool done = false;
};

// Everything, guarded by one mutex that is never held while a callback runs.
struct Standin {
  std::mutex mutex;
  Config config;
  bool open = false;
  HHD handle = 0;
  HDenum calibration = kCalibrationOk;
  bool inkwell = false;
  bool force_output = false;
  int frame_depth = 0;
  int frame_violations = 0;
  double set_force[3] = {0, 0, 0};   // N, last hdSetDoublev(HD_CURRENT_FORCE)
  double set_torque[3] = {0, 0, 0};  // mN·m
  double out_force[3] = {0, 0, 0};   // N, what the motors render (sent at hdEndFrame)
  double out_torque[3] = {0, 0, 0};  // mN·m
  double pos[3] = {0, 0, 0};         // mm
  double vel[3] = {0, 0, 0};         // mm/s
  double hand[3] = {0, 0, 0};        // mm, where the hand pulls the stylus
  // Column-major 3x3 end-effector orientation; at rest the stylus stands in its inkwell, its axis
  // (end-effector +z) up along HD's +y: a quarter turn about x.
  double rot[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
  int buttons = 0;
  bool circle = false;
  bool press_buttons = false;  // CARIESIM_STANDIN_HD=...buttons: buttons 0 and 1 in turn, 0.25 s each
  std::vector<std::pair<double, int>> button_script;  // CARIESIM_STANDIN_HD_BUTTONS: (s, mask), by time
  double scheduler_started = 0.0;                     // s, scheduler time at hdStartScheduler
  double time = 0.0;                                  // s, scheduler time
  std::vector<HDErrorInfo> errors;
  HDerror inject_code = kSuccess;
  int inject_internal = 0;
  int inject_frames = 0;
  bool unplugged = false;   // the cable pulled
  bool dead = false;        // the open handle was unplugged: it stays dead until hdDisableDevice
  double unplug_at = -1.0;  // s of scheduler time (CARIESIM_STANDIN_HD=...unplug-at-Ts)
  double replug_at = -1.0;
  bool unplug_fired = false;
  HHD next_handle_id = 1;
  // Scheduler.
  unsigned long rate = 1000;
  std::vector<Scheduled> scheduled;
  std::vector<Synchronous*> synchronous;
  std::condition_variable synchronous_done;
  HDSchedulerHandle next_handle = 1;
  std::thread thread;
  std::atomic<bool> running{false};
  std::thread::id scheduler_id;
  std::atomic<unsigned long> ticks{0};
};

Standin& state() {
  static Standin s;
  return s;
}

// CARIESIM_STANDIN_HD_BUTTONS's "T:MASK,..." (times in s, increasing); a malformed script is said on
// stderr and ignored.
std::vector<std::pair<double, int>> parse_button_script(const char* text) {
  std::vector<std::pair<double, int>> script;
  if (text == nullptr) return script;
  const char* p = text;
  while (*p != '\0') {
    char* end = nullptr;
    const double at = std::strtod(p, &end);
    if (end == p || *end != ':' || !std::isfinite(at) || (!script.empty() && at < script.back().first)) break;
    p = end + 1;
    const long mask = std::strtol(p, &end, 10);
    if (end == p || mask < 0 || mask > 0xFFFF || (*end != ',' && *end != '\0')) break;
    script.emplace_back(at, static_cast<int>(mask));
    p = *end == ',' ? end + 1 : end;
  }
  if (*p != '\0') {
    std::fprintf(stderr, "standin HD: CARIESIM_STANDIN_HD_BUTTONS: not T:MASK,... at '%s'; ignored\n", p);
    script.clear();
  }
  return script;
}

// Pushes an error (the caller holds the mutex); the stack is bounded like HD's.
void push_error(Standin& s, HDerror code, int internal = 0) {
  if (s.errors.size() < 64) s.errors.push_back({code, internal, s.handle});
}

// The stylus: 50 g, a hand spring of 2 N/mm with critical damping, plus the rendered force.
void simulate(Standin& s, double dt) {
  constexpr double kMass = 0.05;          // kg
  constexpr double kHandStiffness = 2.0;  // N/mm
  constexpr double kHandDamping = 0.02;   // N·s/mm
  constexpr double kSubstep = 1e-4;       // s
  if (s.circle) {
    const double phase = 2.0 * 3.14159265358979 * 0.5 * s.time;
    s.hand[0] = 20.0 * std::cos(phase);
    s.hand[1] = 0.0;
    s.hand[2] = 20.0 * std::sin(phase);
  }
  if (s.press_buttons) s.buttons = 1 << (static_cast<int>(s.time * 4.0) % 2);
  for (const auto& [at, mask] : s.button_script)
    if (s.time - s.scheduler_started >= at) s.buttons = mask;
  if (s.unplug_at >= 0.0 && !s.unplug_fired && s.time >= s.unplug_at) {
    s.unplug_fired = true;
    s.unplugged = true;
    s.dead = s.open;
  }
  if (s.replug_at >= 0.0 && s.unplug_fired && s.unplugged && s.time >= s.replug_at) s.unplugged = false;
  const int steps = std::clamp(static_cast<int>(std::ceil(dt / kSubstep)), 1, 1000);
  const double h = dt / steps;
  for (int k = 0; k < steps; ++k)
    for (int i = 0; i < 3; ++i) {
      const double f = s.out_force[i] + kHandStiffness * (s.hand[i] - s.pos[i]) - kHandDamping * s.vel[i];
      s.vel[i] += f / kMass * 1000.0 * h;  // mm/s² from N/kg
      s.pos[i] += s.vel[i] * h;
    }
  s.time += dt;
}

// The scheduler thread: each tick simulates, runs the asynchronous callbacks (highest priority
// first), then the synchronous ones, and waits for the next tick.
void scheduler_loop() {
  Standin& s = state();
  auto next = std::chrono::steady_clock::now();
  while (s.running.load()) {
    std::vector<Scheduled> callbacks;
    std::vector<Synchronous*> synchronous;
    std::chrono::nanoseconds period{};
    {
      std::lock_guard<std::mutex> lock(s.mutex);
      period = std::chrono::nanoseconds(1000000000 / std::max<unsigned long>(s.rate, 1));
      simulate(s, 1.0 / static_cast<double>(std::max<unsigned long>(s.rate, 1)));
      callbacks = s.scheduled;
      synchronous.swap(s.synchronous);
    }
    std::stable_sort(callbacks.begin(), callbacks.end(),
                     [](const Scheduled& a, const Scheduled& b) { return a.priority > b.priority; });
    for (const Scheduled& c : callbacks)
      if (c.callback(c.data) == kCallbackDone) {
        std::lock_guard<std::mutex> lock(s.mutex);
        std::erase_if(s.scheduled, [&](const Scheduled& x) { return x.handle == c.handle; });
      }
    for (Synchronous* c : synchronous) {
      while (c->callback(c->data) != kCallbackDone) {
      }
      std::lock_guard<std::mutex> lock(s.mutex);
      c->done = true;
    }
    s.synchronous_done.notify_all();
    s.ticks.fetch_add(1);
    next += period;
    std::this_thread::sleep_until(next);
  }
}

// Sends the written wrench to the motors (at the outermost hdEndFrame), by HD's rules.
void commit_forces(Standin& s) {
  const bool on = s.force_output;
  const double norm = std::sqrt(s.set_force[0] * s.set_force[0] + s.set_force[1] * s.set_force[1] +
                                s.set_force[2] * s.set_force[2]);
  const bool too_large = norm > s.config.max_force;
  if (on && too_large) push_error(s, kExceededMaxForce);
  for (int i = 0; i < 3; ++i) {
    s.out_force[i] = on && !too_large ? s.set_force[i] : 0.0;
    s.out_torque[i] = on && s.config.dof_out == 6 ? s.set_torque[i] : 0.0;
  }
}

}  // namespace

extern "C" {

// ---- HD API (hd.h, hdScheduler.h) ----

HHD hdInitDevice(HDstring config_name) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  const char* env = std::getenv("CARIESIM_STANDIN_HD");
  s.circle = env != nullptr && std::strstr(env, "circle") != nullptr;
  s.press_buttons = env != nullptr && std::strstr(env, "buttons") != nullptr;
  s.button_script = parse_button_script(std::getenv("CARIESIM_STANDIN_HD_BUTTONS"));
  if (!s.unplug_fired && env != nullptr) {
    if (const char* at = std::strstr(env, "unplug-at-")) s.unplug_at = s.time + std::atof(at + 10);
    if (const char* at = std::strstr(env, "replug-at-")) s.replug_at = s.time + std::atof(at + 10);
  }
  if (s.unplugged) {
    push_error(s, kDeviceFault);
    return kInvalidHandle;
  }
  if (s.open) {
    push_error(s, kDeviceAlreadyInitiated);
    return kInvalidHandle;
  }
  if (s.config.open_error != kSuccess) {
    push_error(s, s.config.open_error, s.config.open_internal);
    return kInvalidHandle;
  }
  if (config_name == nullptr && s.config.default_fails) {
    push_error(s, kDeviceFault);
    return kInvalidHandle;
  }
  if (config_name != nullptr && s.config.name != config_name) {
    push_error(s, kCommConfigError);
    return kInvalidHandle;
  }
  s.open = true;
  s.dead = false;
  s.handle = s.next_handle_id++;
  s.force_output = true;  // HD enables force output at initialisation
  s.frame_depth = 0;
  return s.handle;
}

void hdDisableDevice(HHD device) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || device != s.handle) {
    push_error(s, kBadHandle);
    return;
  }
  s.open = false;
  s.dead = false;
  for (double& f : s.out_force) f = 0.0;
  for (double& t : s.out_torque) t = 0.0;
}

void hdMakeCurrentDevice(HHD device) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || device != s.handle) push_error(s, kBadHandle);
}

void hdBeginFrame(HHD device) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || device != s.handle) {
    push_error(s, kBadHandle);
    return;
  }
  if (s.frame_depth == 0 && s.dead) push_error(s, kCommError);
  if (s.frame_depth == 0 && s.inject_frames > 0) {
    --s.inject_frames;
    push_error(s, s.inject_code, s.inject_internal);
  }
  ++s.frame_depth;
}

void hdEndFrame(HHD device) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || device != s.handle) {
    push_error(s, kBadHandle);
    return;
  }
  if (s.frame_depth == 0) {
    push_error(s, kIllegalEnd);
    ++s.frame_violations;
    return;
  }
  if (--s.frame_depth == 0) {
    if (s.dead) {
      for (double& f : s.out_force) f = 0.0;  // no motor current through a pulled cable
      for (double& t : s.out_torque) t = 0.0;
    } else {
      commit_forces(s);
    }
  }
}

HDErrorInfo hdGetError() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.errors.empty()) return {kSuccess, 0, s.handle};
  const HDErrorInfo e = s.errors.back();
  s.errors.pop_back();
  return e;
}

void hdEnable(HDenum capability) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (capability == kForceOutput)
    s.force_output = true;
  else
    push_error(s, kInvalidEnum);
}

void hdDisable(HDenum capability) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (capability == kForceOutput) {
    s.force_output = false;
    for (double& f : s.out_force) f = 0.0;
    for (double& t : s.out_torque) t = 0.0;
  } else {
    push_error(s, kInvalidEnum);
  }
}

void hdGetIntegerv(HDenum parameter, HDint* values) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open) {
    push_error(s, kInvalidOperation);
    return;
  }
  switch (parameter) {
    case kCurrentButtons:
      *values = s.buttons;
      break;
    case kCurrentInkwellSwitch:
      *values = s.inkwell ? 1 : 0;
      break;
    case kInputDof:
      *values = s.config.dof_in;
      break;
    case kOutputDof:
      *values = s.config.dof_out;
      break;
    case kCalibrationStyle:
      *values = s.config.calibration_styles;
      break;
    case kUpdateRate:
      *values = static_cast<HDint>(s.rate);
      break;
    default:
      push_error(s, kInvalidEnum);
  }
}

void hdGetDoublev(HDenum parameter, HDdouble* values) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open) {
    push_error(s, kInvalidOperation);
    return;
  }
  switch (parameter) {
    case kCurrentPosition:
      std::copy(s.pos, s.pos + 3, values);
      break;
    case kCurrentVelocity:
      std::copy(s.vel, s.vel + 3, values);
      break;
    case kCurrentAngularVelocity:
      std::fill(values, values + 3, 0.0);
      break;
    case kCurrentTransform:
      for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r) values[4 * c + r] = s.rot[3 * c + r];
        values[4 * c + 3] = 0.0;
      }
      std::copy(s.pos, s.pos + 3, values + 12);
      values[15] = 1.0;
      break;
    case kNominalMaxForce:
      *values = s.config.max_force;
      break;
    case kNominalMaxContinuousForce:
      *values = s.config.continuous_force;
      break;
    case kNominalMaxStiffness:
      *values = s.config.max_stiffness;
      break;
    case kNominalMaxTorqueForce:
      *values = s.config.max_torque;
      break;
    case kUsableWorkspaceDimensions:
      std::copy(s.config.workspace, s.config.workspace + 6, values);
      break;
    default:
      push_error(s, kInvalidEnum);
  }
}

HDstring hdGetString(HDenum parameter) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  switch (parameter) {
    case kVersion:
      return s.config.version.c_str();
    case kDeviceModelType:
      return s.config.model.c_str();
    case kDeviceSerialNumber:
      return s.config.serial.c_str();
    default:
      push_error(s, kInvalidEnum);
      return nullptr;
  }
}

void hdSetDoublev(HDenum parameter, const HDdouble* values) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open) {
    push_error(s, kInvalidOperation);
    return;
  }
  if (s.frame_depth == 0) {  // HD: forces are written inside a frame
    push_error(s, kInvalidOperation);
    ++s.frame_violations;
    return;
  }
  if (parameter == kCurrentForce) {
    std::copy(values, values + 3, s.set_force);
  } else if (parameter == kCurrentTorque && s.config.dof_out == 6) {
    std::copy(values, values + 3, s.set_torque);
  } else {
    push_error(s, kInvalidEnum);
  }
}

HDenum hdCheckCalibration() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || s.frame_depth == 0) {
    push_error(s, kInvalidOperation);
    return kCalibrationNeedsManualInput;
  }
  if (s.calibration == kCalibrationNeedsManualInput && s.inkwell &&
      (s.config.calibration_styles & kCalibrationInkwell) != 0)
    s.calibration = kCalibrationNeedsUpdate;
  return s.calibration;
}

#ifndef STANDIN_HD_WITHOUT_UPDATE_CALIBRATION  // the variant that lacks a symbol
void hdUpdateCalibration(HDenum style) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.open || (s.config.calibration_styles & static_cast<HDint>(style)) == 0) {
    push_error(s, kInvalidValue);
    return;
  }
  if (s.calibration == kCalibrationNeedsUpdate) s.calibration = kCalibrationOk;
}
#endif

void hdStartScheduler() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.running.load()) return;
  s.scheduler_started = s.time;
  s.running = true;
  s.thread = std::thread(scheduler_loop);
  s.scheduler_id = s.thread.get_id();
}

// Returns once the scheduler thread has finished its last tick.
void hdStopScheduler() {
  Standin& s = state();
  if (!s.running.exchange(false)) return;
  if (s.thread.joinable()) s.thread.join();
  std::lock_guard<std::mutex> lock(s.mutex);
  for (Synchronous* c : s.synchronous) c->done = true;
  s.synchronous.clear();
  s.synchronous_done.notify_all();
}

void hdSetSchedulerRate(HDulong rate) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (rate < 100 || rate > 2000)
    push_error(s, kInvalidValue);
  else
    s.rate = rate;
}

HDSchedulerHandle hdScheduleAsynchronous(HDSchedulerCallback callback, void* data, HDushort priority) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.scheduled.size() >= 32) {
    push_error(s, kSchedulerFull);
    return 0;
  }
  s.scheduled.push_back({s.next_handle, callback, data, priority});
  return s.next_handle++;
}

// Runs the callback on the scheduler thread and waits for it (directly when it is not running).
void hdScheduleSynchronous(HDSchedulerCallback callback, void* data, HDushort priority) {
  (void)priority;
  Standin& s = state();
  std::unique_lock<std::mutex> lock(s.mutex);
  if (!s.running.load()) {
    lock.unlock();
    while (callback(data) != kCallbackDone) {
    }
    return;
  }
  Synchronous job{callback, data};
  s.synchronous.push_back(&job);
  s.synchronous_done.wait(lock, [&] { return job.done; });
}

void hdUnschedule(HDSchedulerHandle handle) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  std::erase_if(s.scheduled, [&](const Scheduled& x) { return x.handle == handle; });
}

// ---- test-only functions ----

// Back to a calibrated Touch at rest at the origin (the stylus in its rest orientation), closed, with no
// errors, the scheduler stopped.
void standin_hd_reset() {
  hdStopScheduler();
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.config = Config{};
  s.open = false;
  s.calibration = kCalibrationOk;
  s.inkwell = false;
  s.force_output = false;
  s.frame_depth = 0;
  s.frame_violations = 0;
  for (int i = 0; i < 3; ++i)
    s.set_force[i] = s.set_torque[i] = s.out_force[i] = s.out_torque[i] = s.pos[i] = s.vel[i] = s.hand[i] = 0;
  const double rest[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
  std::copy(rest, rest + 9, s.rot);
  s.buttons = 0;
  s.time = 0.0;
  s.scheduler_started = 0.0;
  s.errors.clear();
  s.inject_frames = 0;
  s.unplugged = s.dead = s.unplug_fired = false;
  s.unplug_at = s.replug_at = -1.0;
  s.rate = 1000;
  s.scheduled.clear();
  s.ticks = 0;
}

// The device's identity and capabilities.
void standin_hd_configure(const char* name, const char* model, int dof_out, int calibration_styles,
                          double max_torque_mnm) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.config.name = name;
  s.config.model = model;
  s.config.dof_out = dof_out;
  s.config.calibration_styles = calibration_styles;
  s.config.max_torque = max_torque_mnm;
}

void standin_hd_set_version(const char* version) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.config.version = version;
}

// Every hdInitDevice fails with `code` (the device's own code `internal`, the driver's errno);
// `default_only`: only HD_DEFAULT_DEVICE fails, with HD_DEVICE_FAULT.
void standin_hd_fail_open(unsigned code, int internal, int default_only) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (default_only != 0) {
    s.config.default_fails = true;
  } else {
    s.config.open_error = code;
    s.config.open_internal = internal;
  }
}

void standin_hd_set_calibration(unsigned status) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.calibration = status;
}

void standin_hd_set_inkwell(int in) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.inkwell = in != 0;
}

// Where the hand pulls the stylus (mm, HD frame).
void standin_hd_push_hand(double x, double y, double z) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.hand[0] = x;
  s.hand[1] = y;
  s.hand[2] = z;
}

// Puts the stylus (and the hand) at a point, at rest.
void standin_hd_place(double x, double y, double z) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  const double p[3] = {x, y, z};
  for (int i = 0; i < 3; ++i) {
    s.pos[i] = s.hand[i] = p[i];
    s.vel[i] = 0.0;
  }
}

// The end effector's orientation as a unit quaternion (w, x, y, z) in HD's frame.
void standin_hd_set_orientation(double w, double x, double y, double z) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + w * z),     2 * (x * z - w * y),
                       2 * (x * y - w * z),     1 - 2 * (x * x + z * z), 2 * (y * z + w * x),
                       2 * (x * z + w * y),     2 * (y * z - w * x),     1 - 2 * (x * x + y * y)};
  std::copy(r, r + 9, s.rot);  // column-major
}

void standin_hd_set_buttons(int buttons) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.buttons = buttons;
}

// The next `frames` frames each raise `code` at hdBeginFrame.
void standin_hd_inject_error(unsigned code, int internal, int frames) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.inject_code = code;
  s.inject_internal = internal;
  s.inject_frames = frames;
}

// The force (N) and torque (mN·m) the motors render now.
void standin_hd_output(double* force, double* torque) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  std::copy(s.out_force, s.out_force + 3, force);
  std::copy(s.out_torque, s.out_torque + 3, torque);
}

int standin_hd_force_output_enabled() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.force_output ? 1 : 0;
}

// Pulls the cable (unplug != 0) or plugs it back (0).
void standin_hd_unplug(int unplug) {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.unplugged = unplug != 0;
  if (s.unplugged) {
    s.dead = s.open;
    for (double& f : s.out_force) f = 0.0;
    for (double& t : s.out_torque) t = 0.0;
  }
}

int standin_hd_is_open() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.open ? 1 : 0;
}

// Forces written outside a frame and frames ended that had not begun.
int standin_hd_frame_violations() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.frame_violations;
}

unsigned long standin_hd_ticks() { return state().ticks.load(); }

int standin_hd_on_scheduler_thread() {
  Standin& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.running.load() && std::this_thread::get_id() == s.scheduler_id ? 1 : 0;
}

}  // extern "C"
