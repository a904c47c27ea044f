// ServoLoop clocked by a device whose SDK owns the servo thread (DeviceClock, as OpenHaptics'
// scheduler does): no thread of the loop's own, each tick runs one cycle on the device's thread with
// the device's period as dt, stop returns after the last tick, the force goes through safety and
// the cycle allocates nothing. No wall-clock timing is asserted.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/device.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using test::friction_block;
using test::wait_for;

// A device with its own scheduler thread ticking at `rate` Hz; it presses the tool `depth` mm into
// the block once `press` is set, and remembers on which thread it was read and what it was sent.
class ClockedDevice : public Device, public DeviceClock {
 public:
  ClockedDevice(const Model& model, double rate) : model_(model), rate_(rate) {}
  ~ClockedDevice() override { stop_clock(); }
  [[nodiscard]] DeviceInfo info() const override { return {"clocked", "test", DeviceLimits{}, true}; }
  DeviceClock* clock() override { return this; }
  [[nodiscard]] double rate_hz() const override { return rate_; }
  void start_clock(Tick tick, void* context) override {
    if (refuse) throw Error("scheduler refused: test");
    ticking_.store(true);
    thread_ = std::thread([this, tick, context] {
      scheduler_thread.store(std::this_thread::get_id());
      const auto period = std::chrono::duration<double>(1.0 / rate_);
      auto next = std::chrono::steady_clock::now();
      while (ticking_.load()) {
        in_tick.store(true);
        tick(context);
        in_tick.store(false);
        ticks.fetch_add(1);
        next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
        std::this_thread::sleep_until(next);
      }
    });
  }
  void stop_clock() override {
    ticking_.store(false);
    if (thread_.joinable()) thread_.join();
  }
  DeviceState read(double now) override {
    read_thread.store(std::this_thread::get_id());
    DeviceState s;
    s.pose = model_.tool_home;
    if (press.load()) s.pose.p = Vec3(model_.tool_home.p.x(), 0.0, -0.5);
    s.stamp = now;
    s.sequence = ++sequence_;
    s.valid = true;
    last_now.store(now);
    return s;
  }
  void write(const Vec3& force, const Vec3& /*torque*/) override {
    if (!in_tick.load()) writes_outside.fetch_add(1);
    last_force_z.store(force.z());
  }

  std::atomic<bool> press{false};
  bool refuse = false;
  std::atomic<std::thread::id> scheduler_thread{}, read_thread{};
  std::atomic<uint64_t> ticks{0}, writes_outside{0};
  std::atomic<double> last_now{0.0}, last_force_z{0.0};
  std::atomic<bool> in_tick{false};

 private:
  const Model& model_;
  double rate_;
  std::atomic<bool> ticking_{false};
  std::thread thread_;
  uint64_t sequence_ = 0;
};

ServoOptions options() {
  ServoOptions o;
  o.realtime = false;
  o.rate_hz = 1000.0;  // ignored: the device's clock sets the rate
  o.safety.ramp_time = 0.0;
  return o;
}

TEST(DeviceClock, TheDevicesTicksRunTheCyclesOnItsThreadAtItsPeriod) {
  const Model& m = friction_block();
  ClockedDevice device(m, 500.0);
  ServoLoop loop(m, device, options());
  loop.start();
  EXPECT_DOUBLE_EQ(loop.dt(), 0.002);
  EXPECT_NE(loop.realtime_status().find("clocked by the device"), std::string::npos);
  ASSERT_TRUE(wait_for([&] { return loop.timing().cycles >= 100; }));
  EXPECT_EQ(device.read_thread.load(), device.scheduler_thread.load());
  // Servo time advances by the device's period per tick.
  ServoSnapshot snap;
  ASSERT_TRUE(wait_for([&] { return loop.latest(snap) && snap.cycle >= 100; }));
  EXPECT_NEAR(snap.t, static_cast<double>(snap.cycle - 1) * 0.002, 1e-9);
  loop.stop();
  // Every cycle was one tick; after stop nothing ticks, and the zero force was written last.
  const uint64_t cycles = loop.timing().cycles;
  EXPECT_EQ(cycles, device.ticks.load());
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(device.ticks.load(), cycles);
  EXPECT_EQ(device.last_force_z.load(), 0.0);
  EXPECT_EQ(device.writes_outside.load(), 1u);  // only stop()'s zero wrench
}

TEST(DeviceClock, TheForceOfAPressComesThroughTheDevicesTicks) {
  const Model& m = friction_block();
  ClockedDevice device(m, 1000.0);
  ServoLoop loop(m, device, options());
  loop.start();
  device.press.store(true);
  ASSERT_TRUE(wait_for([&] { return device.last_force_z.load() > 0.1; }));
  loop.stop();
}

TEST(DeviceClock, TheClockedCycleAllocatesNothing) {
  const Model& m = friction_block();
  ClockedDevice device(m, 1000.0);
  ServoLoop loop(m, device, options());
  loop.start();
  device.press.store(true);
  ASSERT_TRUE(wait_for([&] { return loop.timing().cycles >= 200; }));
  // Count across cycles while no other thread of the test allocates (this one only sleeps).
  const std::size_t before = test::allocation_count();
  const uint64_t from = loop.timing().cycles;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const std::size_t after = test::allocation_count();
  ASSERT_GT(loop.timing().cycles, from + 50);
  loop.stop();
  EXPECT_EQ(after, before);
}

TEST(DeviceClock, ASchedulerThatRefusesStopsTheDeviceAndSaysWhy) {
  const Model& m = friction_block();
  ClockedDevice device(m, 1000.0);
  device.refuse = true;
  ServoLoop loop(m, device, options());
  try {
    loop.start();
    FAIL() << "started";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scheduler refused"), std::string::npos);
  }
  EXPECT_FALSE(loop.running());
}

}  // namespace
}  // namespace cariesim
