// A stand-in for Force Dimension's DHD/DRD SDK (test code, never installed): the C functions the
// `fd` backend resolves (src/device/fd_api.hpp), over simulated devices whose handle has mass and
// damping and is held by a hand (a spring toward a hand position) and pushed by the commanded force
// once the force is enabled. Units and frames are the SDK's: m, m/s, N, N·m; x toward the operator,
// y right, z up. Homing: a device starts homed or not (configuration); drdAutoInit homes it (and
// moves the handle to the centre), except the Falcon, which is homed by hand: its handle must reach
// the front of its workspace (x > 40 mm), then the back (x < -40 mm). Errors are the SDK's codes,
// told by dhdErrorGetLast / dhdErrorGetLastStr.
//
// Built in several variants (tests/CMakeLists.txt): libdrd.so.3 (DRD and DHD), libdhd.so.3 (DHD
// only: STANDIN_FD_NO_DRD), an old SDK (STANDIN_FD_VERSION_* older than the backend needs, without
// the 3.3 function dhdSetForceAndTorqueAndGripperForce) and one without dhdGetOrientationFrame.
//
// The devices: CARIESIM_STANDIN_FD_DEVICES="MODEL:SERIAL[:unhomed],..." (default "omega.6:11001"),
// MODEL one of omega.3, omega.6, omega.7, delta.3, delta.6, sigma.7, sigma.6+, lambda.7, falcon.
// CARIESIM_STANDIN_FD_HAND="circle:RADIUS_MM:PERIOD_S" moves every hand on a horizontal circle (for
// `cariesim servo` and `cariesim run` end to end); otherwise the hands stay where tests put them.
// Test-only functions (standin_fd_*) move the hand, set buttons, inject errors, read the force.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

#include "device/fd_api.hpp"

#define STANDIN_EXPORT extern "C" __attribute__((visibility("default")))

#ifndef STANDIN_FD_VERSION_MAJOR
#define STANDIN_FD_VERSION_MAJOR 3
#define STANDIN_FD_VERSION_MINOR 17
#define STANDIN_FD_VERSION_RELEASE 6
#endif

namespace {

namespace fd = cariesim::fd;

constexpr int kMaxDevices = 4;
constexpr double kMass = 0.2;             // kg, the handle
constexpr double kDamping = 4.0;          // N·s/m
constexpr double kHandStiffness = 400.0;  // N/m, the hand holding the handle
constexpr double kStep = 2.5e-4;          // s, the simulation's step
constexpr double kFalconFront = 0.04;     // m, the hand-homing marks of the Falcon

struct Dev {
  int type = fd::kDeviceOmega33;
  const char* name = "omega.6";
  unsigned short serial = 0;
  bool open = false, drd_open = false, homed = true, force_on = false, busy = false;
  bool falcon_front = false;  // the Falcon's hand homing reached the front
  double p[3] = {0, 0, 0}, v[3] = {0, 0, 0}, hand[3] = {0, 0, 0};
  double frame[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double w[3] = {0, 0, 0};
  unsigned buttons = 0;
  double force[3] = {0, 0, 0}, torque[3] = {0, 0, 0}, gripper = 0;  // N, N·m, N as commanded
  int error_code = 0, error_calls = 0;  // injected: the next `error_calls` calls fail (< 0: all)
  int autoinit_count = 0;
  bool unplugged = false;    // standin_fd_unplug: every call fails with DHD_ERROR_COM, opening finds none
  bool dead_handle = false;  // open when unplugged: the handle stays dead until dhdClose
};

struct Sdk {
  std::mutex mutex;
  bool configured = false;
  bool deny_access = false;
  std::vector<Dev> devices;
  double circle_radius = 0.0, circle_period = 0.0;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now(), last = start;
  int error = 0;
};

Sdk& sdk() {
  static Sdk s;
  return s;
}

thread_local int t_last_error = 0;  // dhdErrorGetLast is per thread in the SDK too

struct ModelName {
  const char* key;
  int type;
  const char* name;
};
constexpr std::array<ModelName, 9> kModelNames = {{
    {"omega.3", fd::kDeviceOmega3, "omega.3"},
    {"omega.6", fd::kDeviceOmega33, "omega.6"},
    {"omega.7", fd::kDeviceOmega331, "omega.7"},
    {"delta.3", fd::kDeviceDelta3, "delta.3"},
    {"delta.6", fd::kDeviceDelta6, "delta.6"},
    {"sigma.7", fd::kDeviceSigma331, "sigma.7"},
    {"sigma.6+", fd::kDeviceSigma33p, "sigma.6+"},
    {"lambda.7", fd::kDeviceLambda331, "lambda.7"},
    {"falcon", fd::kDeviceFalcon, "Falcon"},
}};

// "MODEL:SERIAL[:unhomed],..." -> devices (unknown models are skipped).
void configure(Sdk& s, const char* text) {
  s.devices.clear();
  s.deny_access = false;
  std::string_view rest(text != nullptr ? text : "omega.6:11001");
  while (!rest.empty() && s.devices.size() < kMaxDevices) {
    const std::size_t comma = rest.find(',');
    std::string entry(rest.substr(0, comma));
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    Dev d;
    const std::size_t c1 = entry.find(':');
    const std::string key = entry.substr(0, c1);
    bool known = false;
    for (const ModelName& m : kModelNames)
      if (key == m.key) {
        d.type = m.type;
        d.name = m.name;
        known = true;
      }
    if (!known) continue;
    if (c1 != std::string::npos) {
      d.serial = static_cast<unsigned short>(std::atoi(entry.c_str() + c1 + 1));
      d.homed = entry.find(":unhomed") == std::string::npos;
    }
    s.devices.push_back(d);
  }
  s.configured = true;
}

// The state, configured on first use; the caller holds the lock.
Sdk& state() {
  Sdk& s = sdk();
  if (!s.configured) {
    configure(s, std::getenv("CARIESIM_STANDIN_FD_DEVICES"));
    if (const char* hand = std::getenv("CARIESIM_STANDIN_FD_HAND")) {
      double r = 0.0, period = 0.0;
      if (std::sscanf(hand, "circle:%lf:%lf", &r, &period) == 2 && period > 0.0) {
        s.circle_radius = r * 1e-3;
        s.circle_period = period;
      }
    }
  }
  return s;
}

// Advances every device to now: m a = k_hand (hand - p) - b v + F (when the force is on).
void advance(Sdk& s) {
  const auto now = std::chrono::steady_clock::now();
  double elapsed = std::chrono::duration<double>(now - s.last).count();
  s.last = now;
  elapsed = std::min(elapsed, 1.0);  // at most 4000 steps per call
  const double t = std::chrono::duration<double>(now - s.start).count();
  for (Dev& d : s.devices) {
    if (s.circle_period > 0.0) {
      const double phase = 2.0 * std::numbers::pi * t / s.circle_period;
      d.hand[0] = s.circle_radius * std::cos(phase);
      d.hand[1] = s.circle_radius * std::sin(phase);
    }
    for (double done = 0.0; done < elapsed; done += kStep) {
      const double dt = std::min(kStep, elapsed - done);
      for (int i = 0; i < 3; ++i) {
        const double f =
            kHandStiffness * (d.hand[i] - d.p[i]) - kDamping * d.v[i] + (d.force_on ? d.force[i] : 0.0);
        d.v[i] += f / kMass * dt;
        d.p[i] += d.v[i] * dt;
      }
    }
    // The Falcon's hand homing: the front of its workspace, then the back.
    if (d.type == fd::kDeviceFalcon && !d.homed) {
      if (d.p[0] > kFalconFront) d.falcon_front = true;
      if (d.falcon_front && d.p[0] < -kFalconFront) d.homed = true;
    }
  }
}

int fail(int code) {
  t_last_error = code;
  return -1;
}

// The open device of an ID, or null with the SDK's error set; an injected error fails the call.
Dev* device(Sdk& s, char id) {
  if (id < 0 || id >= static_cast<int>(s.devices.size()) || !s.devices[static_cast<std::size_t>(id)].open) {
    fail(fd::kErrorInvalidIndex);
    return nullptr;
  }
  Dev& d = s.devices[static_cast<std::size_t>(id)];
  if (d.unplugged || d.dead_handle) {
    d.force_on = false;  // no power to the motors through a pulled cable
    fail(fd::kErrorCom);
    return nullptr;
  }
  if (d.error_calls != 0) {
    if (d.error_calls > 0) --d.error_calls;
    fail(d.error_code);
    // The controller's watchdog: a lost link switches the motors off.
    if (d.error_code == fd::kErrorCom || d.error_code == fd::kErrorNoDeviceFound) d.force_on = false;
    return nullptr;
  }
  t_last_error = fd::kNoError;
  return &d;
}

int open_index(Sdk& s, int index) {
  if (s.devices.empty()) return fail(fd::kErrorNoDeviceFound);
  if (index < 0 || index >= static_cast<int>(s.devices.size())) return fail(fd::kErrorNoDeviceFound);
  if (s.deny_access) return fail(fd::kErrorNoDriverFound);
  Dev& d = s.devices[static_cast<std::size_t>(index)];
  if (d.unplugged) return fail(fd::kErrorNoDeviceFound);
  if (d.busy || d.open) return fail(fd::kErrorDeviceInUse);
  d.open = true;
  d.force_on = true;  // as the SDK does: a device opens with its force enabled
  t_last_error = fd::kNoError;
  return index;
}

const char* error_text(int code) {
  switch (code) {
    case fd::kNoError:
      return "no error";
    case fd::kErrorCom:
      return "communication error between the host and the device";
    case fd::kErrorDhcBusy:
      return "device controller busy";
    case fd::kErrorNoDriverFound:
      return "required driver not installed";
    case fd::kErrorNoDeviceFound:
      return "no compatible device found";
    case fd::kErrorTimeout:
      return "communication timeout";
    case fd::kErrorDeviceNotReady:
      return "device not ready";
    case fd::kErrorInvalidIndex:
      return "invalid index";
    case fd::kErrorNotImplemented:  // the SDK's answer to drdAutoInit on a Falcon (no robotic homing)
      return "not supported by this device";
    case fd::kErrorDeviceInUse:
      return "device in use";
    default:
      return "undocumented error";
  }
}

}  // namespace

// --- DHD -----------------------------------------------------------------------------------------

STANDIN_EXPORT void dhdGetSDKVersion(int* major, int* minor, int* release, int* revision) {
  *major = STANDIN_FD_VERSION_MAJOR;
  *minor = STANDIN_FD_VERSION_MINOR;
  *release = STANDIN_FD_VERSION_RELEASE;
  *revision = 4242;
}

STANDIN_EXPORT int dhdErrorGetLast() { return t_last_error; }
STANDIN_EXPORT const char* dhdErrorGetLastStr() { return error_text(t_last_error); }

STANDIN_EXPORT int dhdGetDeviceCount() {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  return static_cast<int>(state().devices.size());
}

STANDIN_EXPORT int dhdOpenID(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  return open_index(state(), id);
}

STANDIN_EXPORT int dhdOpenSerial(int serial) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Sdk& st = state();
  for (std::size_t i = 0; i < st.devices.size(); ++i)
    if (st.devices[i].serial == serial) return open_index(st, static_cast<int>(i));
  return fail(fd::kErrorNoDeviceFound);
}

STANDIN_EXPORT int dhdClose(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Sdk& st = state();
  // An unplugged device's handle is released all the same.
  if (id >= 0 && id < static_cast<int>(st.devices.size())) {
    Dev& dead = st.devices[static_cast<std::size_t>(id)];
    if (dead.open && (dead.unplugged || dead.dead_handle)) {
      dead.open = false;
      dead.drd_open = false;
      dead.dead_handle = false;
      t_last_error = fd::kNoError;
      return 0;
    }
  }
  Dev* d = device(st, id);
  if (d == nullptr) return -1;
  d->open = false;
  d->drd_open = false;
  return 0;
}

STANDIN_EXPORT int dhdGetSystemType(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  return d == nullptr ? -1 : d->type;
}

STANDIN_EXPORT const char* dhdGetSystemName(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  return d == nullptr ? nullptr : d->name;
}

STANDIN_EXPORT int dhdGetSerialNumber(unsigned short* serial, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  *serial = d->serial;
  return 0;
}

STANDIN_EXPORT int dhdEnableForce(unsigned char on, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  if (on != 0 && !d->homed) return fail(fd::kErrorDeviceNotReady);
  d->force_on = on != 0;
  return 0;
}

STANDIN_EXPORT int dhdGetPosition(double* x, double* y, double* z, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  advance(state());
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  *x = d->p[0];
  *y = d->p[1];
  *z = d->p[2];
  return 0;
}

#ifndef STANDIN_FD_NO_ORIENTATION_FRAME
STANDIN_EXPORT int dhdGetOrientationFrame(double matrix[3][3], char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) matrix[r][c] = d->frame[r * 3 + c];
  return 0;
}
#endif

STANDIN_EXPORT int dhdGetLinearVelocity(double* vx, double* vy, double* vz, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  *vx = d->v[0];
  *vy = d->v[1];
  *vz = d->v[2];
  return 0;
}

STANDIN_EXPORT int dhdGetAngularVelocityRad(double* wx, double* wy, double* wz, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  *wx = d->w[0];
  *wy = d->w[1];
  *wz = d->w[2];
  return 0;
}

STANDIN_EXPORT unsigned int dhdGetButtonMask(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Sdk& st = state();
  if (id < 0 || id >= static_cast<int>(st.devices.size())) return 0;
  return st.devices[static_cast<std::size_t>(id)].buttons;
}

namespace {
int set_wrench(char id, double fx, double fy, double fz, double tx, double ty, double tz, double fg) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  advance(state());
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  const double f[3] = {fx, fy, fz}, t[3] = {tx, ty, tz};
  for (int i = 0; i < 3; ++i) {
    d->force[i] = f[i];
    d->torque[i] = t[i];
  }
  d->gripper = fg;
  return 0;
}
}  // namespace

STANDIN_EXPORT int dhdSetForceAndTorque(double fx, double fy, double fz, double tx, double ty, double tz,
                                        char id) {
  return set_wrench(id, fx, fy, fz, tx, ty, tz, 0.0);
}

#if STANDIN_FD_VERSION_MAJOR > 3 || (STANDIN_FD_VERSION_MAJOR == 3 && STANDIN_FD_VERSION_MINOR >= 3)
STANDIN_EXPORT int dhdSetForceAndTorqueAndGripperForce(double fx, double fy, double fz, double tx, double ty,
                                                       double tz, double fg, char id) {
  return set_wrench(id, fx, fy, fz, tx, ty, tz, fg);
}
#endif

// --- DRD -----------------------------------------------------------------------------------------

#ifndef STANDIN_FD_NO_DRD
STANDIN_EXPORT int drdOpenID(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  d->drd_open = true;
  return id;
}

STANDIN_EXPORT int drdClose(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr || !d->drd_open) return -1;
  d->drd_open = false;
  return 0;
}

STANDIN_EXPORT bool drdIsInitialized(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  advance(state());
  Dev* d = device(state(), id);
  return d != nullptr && d->drd_open && d->homed;
}

STANDIN_EXPORT int drdAutoInit(char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr) return -1;
  if (!d->drd_open || d->type == fd::kDeviceFalcon) return fail(fd::kErrorNotImplemented);
  ++d->autoinit_count;
  d->homed = true;
  for (int i = 0; i < 3; ++i) d->p[i] = d->v[i] = d->hand[i] = 0.0;
  return 0;
}

STANDIN_EXPORT int drdStop(bool keep_forces, char id) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev* d = device(state(), id);
  if (d == nullptr || !d->drd_open) return -1;
  d->force_on = keep_forces;
  return 0;
}
#endif

// --- test-only -----------------------------------------------------------------------------------

/// Replaces the devices ("MODEL:SERIAL[:unhomed],...", as CARIESIM_STANDIN_FD_DEVICES) and clears all state.
STANDIN_EXPORT void standin_fd_configure(const char* devices) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  configure(s, devices);
  s.circle_period = 0.0;
}

/// Moves the hand holding device `index` to (x, y, z) m; the handle follows through the hand's spring.
STANDIN_EXPORT void standin_fd_set_hand(int index, double x, double y, double z) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev& d = state().devices.at(static_cast<std::size_t>(index));
  d.hand[0] = x;
  d.hand[1] = y;
  d.hand[2] = z;
}

/// Puts the handle (and the hand) at (x, y, z) m at rest.
STANDIN_EXPORT void standin_fd_place(int index, double x, double y, double z) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Sdk& st = state();
  advance(st);
  Dev& d = st.devices.at(static_cast<std::size_t>(index));
  const double p[3] = {x, y, z};
  for (int i = 0; i < 3; ++i) {
    d.p[i] = d.hand[i] = p[i];
    d.v[i] = 0.0;
  }
  if (d.type == fd::kDeviceFalcon && !d.homed) {
    if (x > kFalconFront) d.falcon_front = true;
    if (d.falcon_front && x < -kFalconFront) d.homed = true;
  }
}

/// Sets the end effector's orientation frame (row-major 3 x 3, device frame).
STANDIN_EXPORT void standin_fd_set_frame(int index, const double* frame) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  std::memcpy(state().devices.at(static_cast<std::size_t>(index)).frame, frame, sizeof(double) * 9);
}

STANDIN_EXPORT void standin_fd_set_buttons(int index, unsigned mask) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  state().devices.at(static_cast<std::size_t>(index)).buttons = mask;
}

/// The next `calls` SDK calls on device `index` fail with `code` (calls < 0: until injected again).
STANDIN_EXPORT void standin_fd_inject_error(int index, int code, int calls) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev& d = state().devices.at(static_cast<std::size_t>(index));
  d.error_code = code;
  d.error_calls = calls;
}

/// The last wrench commanded (N, N·m, gripper N) into out[7]; returns 1 when the force is enabled.
STANDIN_EXPORT int standin_fd_wrench(int index, double* out) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  const Dev& d = state().devices.at(static_cast<std::size_t>(index));
  for (int i = 0; i < 3; ++i) {
    out[i] = d.force[i];
    out[3 + i] = d.torque[i];
  }
  out[6] = d.gripper;
  return d.force_on ? 1 : 0;
}

/// 1 when the device is open (dhdOpen*), 0 once closed.
STANDIN_EXPORT int standin_fd_is_open(int index) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  return state().devices.at(static_cast<std::size_t>(index)).open ? 1 : 0;
}

/// How many times drdAutoInit homed the device.
STANDIN_EXPORT int standin_fd_autoinit_count(int index) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  return state().devices.at(static_cast<std::size_t>(index)).autoinit_count;
}

/// Marks the device as opened by another program (dhdOpen* fails with DHD_ERROR_DEVICE_IN_USE).
STANDIN_EXPORT void standin_fd_set_busy(int index, int busy) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  state().devices.at(static_cast<std::size_t>(index)).busy = busy != 0;
}

/// Denies this user the USB devices (dhdOpen* fails with DHD_ERROR_NO_DRIVER_FOUND).
STANDIN_EXPORT void standin_fd_deny_access(int deny) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  state().deny_access = deny != 0;
}

/// Pulls the device's cable (unplug != 0): every call on it fails with DHD_ERROR_COM and its motors
/// stop; opening it finds no device. Plugging it back (0) lets it be opened again (its handle, if
/// still open, stays dead until closed).
STANDIN_EXPORT void standin_fd_unplug(int index, int unplug) {
  Sdk& s = sdk();
  const std::lock_guard<std::mutex> lock(s.mutex);
  Dev& d = state().devices.at(static_cast<std::size_t>(index));
  d.unplugged = unplug != 0;
  if (d.unplugged) {
    d.force_on = false;
    d.dead_handle = d.open;
  }
}
