// What a hardware device's mapping costs each servo cycle (docs/devices.md): HapticDevice::read and
// write (profile mapping, clutch, buttons to actions, force gate, ramp, continuous-force model, torque
// policy, the inverse rotation) over a hardware device that only hands back a moving reading, so the
// time is HapticDevice's own, not an SDK's.
//
// BM_HapticDeviceCycle/dof:3 and /dof:6: one read + write per iteration, the hand circling and the
// force changing; Google Benchmark's mean and median over repetitions, plus the per-cycle 50th, 99th
// and 99.9th percentiles (ns) as counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "cariesim/device/haptic_device.hpp"

namespace {

using cariesim::Calibration;
using cariesim::HardwareDevice;
using cariesim::HardwareInfo;
using cariesim::HardwareReading;
using cariesim::Readiness;
using cariesim::Vec3;

// A hand circling 20 mm in the device's frame; the wrench written is kept (the optimiser keeps it).
class CirclingHand final : public HardwareDevice {
 public:
  explicit CirclingHand(int dof_out) {
    info_.backend = "bench";
    info_.model = "circling hand";
    info_.dof_out = dof_out;
    info_.max_force = 3.3;
    info_.continuous_force = 0.88;
    info_.max_stiffness = 1.26;
    info_.max_torque = dof_out >= 6 ? 500.0 : 0.0;
    info_.workspace = Eigen::AlignedBox3d(Vec3(-80, -60, -35), Vec3(80, 60, 35));
  }
  void open() override {}
  void close() override {}
  [[nodiscard]] HardwareInfo info() const override { return info_; }
  Calibration calibrate() override { return {Readiness::Ready, "ready"}; }
  HardwareReading read() override {
    phase_ += 0.00314;
    HardwareReading r;
    r.pose.p = Vec3(20.0 * std::cos(phase_), 0.0, 20.0 * std::sin(phase_));
    r.velocity = Vec3(-62.8 * std::sin(phase_), 0.0, 62.8 * std::cos(phase_));
    r.buttons = (static_cast<int>(phase_) % 7 == 0) ? 1u : 0u;  // the clutch now and then
    r.valid = true;
    return r;
  }
  void write(const Vec3& force, const Vec3& torque) override { sink_ += force.x() + torque.y(); }
  void enable_force(bool /*on*/) override {}
  double sink_ = 0.0;

 private:
  HardwareInfo info_;
  double phase_ = 0.0;
};

void BM_HapticDeviceCycle(benchmark::State& state) {
  cariesim::HapticDevice device(std::make_unique<CirclingHand>(static_cast<int>(state.range(0))),
                                cariesim::DeviceProfile{}, cariesim::Pose{});
  device.start();
  std::vector<double> ns;
  ns.reserve(1 << 20);
  double t = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const cariesim::DeviceState s = device.read(t);
    device.write(Vec3(0.3 * std::sin(t), 0.2, 1.0), Vec3(0.0, 20.0, 0.0));
    benchmark::DoNotOptimize(s);
    const auto end = std::chrono::steady_clock::now();
    if (ns.size() < ns.capacity())
      ns.push_back(std::chrono::duration<double, std::nano>(end - start).count());
    t += 0.001;
  }
  device.stop();
  std::sort(ns.begin(), ns.end());
  const auto at = [&](double p) {
    return ns.empty() ? 0.0 : ns[static_cast<std::size_t>(p * (ns.size() - 1))];
  };
  state.counters["p50_ns"] = at(0.5);
  state.counters["p99_ns"] = at(0.99);
  state.counters["p999_ns"] = at(0.999);
}
BENCHMARK(BM_HapticDeviceCycle)->ArgName("dof")->Arg(3)->Arg(6)->Repetitions(5);

}  // namespace

BENCHMARK_MAIN();
