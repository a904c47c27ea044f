// The servo loop clocked by the `touch` backend (OpenHaptics HD) through HapticDevice, made by the
// device factory (`touch`) over the stand-in libHD.so (tests/device/standins/hd): the loop runs its
// cycles in HD's scheduler callback at HD's rate; pressing the stylus down onto the friction block
// gives a force up along HD's own +y (HD: x right, y up, z toward the user), within the Touch's
// limits; stopping switches the device's force off and releases it.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <numbers>

#include "cariesim/device/factory.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"

namespace cariesim {
namespace {

using test::friction_block;
using test::wait_for;

// The stand-in's test-only functions.
class Standin {
 public:
  Standin() : handle_(dlopen(CARIESIM_STANDIN_HD, RTLD_NOW | RTLD_LOCAL)) {
    if (handle_ == nullptr) throw std::runtime_error(std::string("stand-in: ") + dlerror());
    reset = fn<void (*)()>("standin_hd_reset");
    push_hand = fn<void (*)(double, double, double)>("standin_hd_push_hand");
    set_orientation = fn<void (*)(double, double, double, double)>("standin_hd_set_orientation");
    output = fn<void (*)(double*, double*)>("standin_hd_output");
    force_output_enabled = fn<int (*)()>("standin_hd_force_output_enabled");
    is_open = fn<int (*)()>("standin_hd_is_open");
    frame_violations = fn<int (*)()>("standin_hd_frame_violations");
  }
  ~Standin() { dlclose(handle_); }
  Standin(const Standin&) = delete;
  Standin& operator=(const Standin&) = delete;
  [[nodiscard]] Vec3 force() const {
    double f[3];
    double t[3];
    output(f, t);
    return {f[0], f[1], f[2]};
  }
  void (*reset)();
  void (*push_hand)(double, double, double);
  void (*set_orientation)(double, double, double, double);
  void (*output)(double*, double*);
  int (*force_output_enabled)();
  int (*is_open)();
  int (*frame_violations)();

 private:
  template <class F>
  F fn(const char* name) {
    void* address = dlsym(handle_, name);
    if (address == nullptr) throw std::runtime_error(std::string("stand-in lacks ") + name);
    return reinterpret_cast<F>(address);
  }
  void* handle_;
};

TEST(TouchServo, TheLoopRunsInHdsSchedulerAndAPressDownIsPushedBackUpAlongHdsY) {
  setenv("CARIESIM_HD_LIBRARY", CARIESIM_STANDIN_HD, 1);
  Standin standin;
  standin.reset();
  // The stylus at rest orientation (its axis up, HD +y), so the tool starts at the home orientation.
  const double half = -std::numbers::pi / 4.0;
  standin.set_orientation(std::cos(half), std::sin(half), 0.0, 0.0);
  const Model& m = friction_block();
  DeviceOptions device_options;
  device_options.home = m.tool_home;
  device_options.limits = m.defaults.limits;
  auto device = make_device("touch", device_options);
  ServoOptions options;
  options.realtime = false;
  ServoLoop loop(m, *device, options);
  loop.start();
  EXPECT_NE(loop.realtime_status().find("clocked by the device's scheduler at 1000 Hz"), std::string::npos)
      << loop.realtime_status();
  EXPECT_DOUBLE_EQ(loop.dt(), 0.001);
  // Out of contact at home: the force switch goes on.
  ASSERT_TRUE(wait_for([&] { return standin.force_output_enabled() == 1; }, std::chrono::seconds(10)));
  // The hand pushes the stylus down (HD -y) until the tip is 1 mm into the block (top at z = 0).
  const double down = m.tool_home.p.z() + 1.0;
  standin.push_hand(0.0, -down, 0.0);
  ASSERT_TRUE(wait_for([&] { return standin.force().y() > 0.2; }, std::chrono::seconds(10)))
      << standin.force().transpose();
  const Vec3 f = standin.force();
  EXPECT_GT(f.y(), 0.0);
  EXPECT_LT(std::hypot(f.x(), f.z()), 0.5 * f.y()) << f.transpose();
  EXPECT_LE(f.norm(), 3.3 + 1e-9) << "within the Touch's nominal maximum";
  loop.stop();
  EXPECT_GT(loop.timing().cycles, 0u);
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.force(), Vec3::Zero());
  EXPECT_EQ(standin.is_open(), 0);
  EXPECT_EQ(standin.frame_violations(), 0);
  standin.reset();
  unsetenv("CARIESIM_HD_LIBRARY");
}

}  // namespace
}  // namespace cariesim
