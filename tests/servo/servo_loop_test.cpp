// ServoLoop with the real engine on the built-in friction-block scene: cycles happen, snapshots
// arrive, samples flow (and drops are counted), parameter changes reach the running Params and are
// published, a device's announced limits tighten them, start/stop/start works, and the running cycle
// allocates nothing; the spin before each deadline is checked and capped at half the period. No
// wall-clock timing is asserted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>
#include <vector>

#include "cariesim/common/cpu.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "cariesim/servo/servo.hpp"
#include "servo/servo_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using test::friction_block;
using test::wait_for;

// Holds a pose; counts starts and stops; remembers what was written (read it after stop()).
class HoldDevice : public Device {
 public:
  explicit HoldDevice(const Pose& pose) : pose_(pose) {}
  [[nodiscard]] DeviceInfo info() const override { return DeviceInfo{"hold", "test", DeviceLimits{}, true}; }
  void start() override { starts.fetch_add(1); }
  void stop() override { stops.fetch_add(1); }
  DeviceState read(double now) override {
    reads.fetch_add(1, std::memory_order_relaxed);
    DeviceState s;
    s.pose = pose_;
    s.stamp = now;
    s.sequence = ++sequence_;
    s.valid = true;
    s.buttons = 5;
    return s;
  }
  void write(const Vec3& force, const Vec3& torque) override {
    last_force = force;
    last_torque = torque;
    writes.fetch_add(1, std::memory_order_relaxed);
  }
  void set_status(const DeviceStatus& status) override {
    last_status = status;
    acknowledged.store(status.limits_acknowledged);
  }
  bool poll_limits(LimitsAnnouncement& out) override { return announced.read(out); }

  std::atomic<int> starts{0}, stops{0};
  std::atomic<uint64_t> reads{0}, writes{0};
  Vec3 last_force = Vec3::Constant(-1.0), last_torque = Vec3::Zero();
  DeviceStatus last_status;
  std::atomic<bool> acknowledged{false};       // the last status' limits_acknowledged (any thread)
  TripleBuffer<LimitsAnnouncement> announced;  // what the test "device" announces (test -> servo thread)

 private:
  Pose pose_;
  uint64_t sequence_ = 0;
};

ServoOptions quiet_options() {
  ServoOptions o;
  o.realtime = false;
  return o;
}

// The home pose lowered so the tip is `depth` mm below the block's top (z = 0).
Pose pressing(const Model& m, double depth) { return test::home_at(m, Vec3(m.tool_home.p.x(), 0.0, -depth)); }

TEST(ServoLoop, RejectsRatesOutsideTheRange) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  for (double rate : {0.0, -5.0, 10001.0, std::nan("")}) {
    ServoOptions o = quiet_options();
    o.rate_hz = rate;
    EXPECT_THROW(ServoLoop(m, d, o), Error) << rate;
  }
  ServoOptions o = quiet_options();
  o.rate_hz = 10000.0;
  ServoLoop fast(m, d, o);
  EXPECT_DOUBLE_EQ(fast.dt(), 1e-4);
}

TEST(ServoLoop, RejectsSpinsOutsideTheRangeAndPollsAtMostHalfThePeriod) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  for (double spin : {-1.0, 10001.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    ServoOptions o = quiet_options();
    o.spin_us = spin;
    try {
      ServoLoop loop(m, d, o);
      ADD_FAILURE() << "spin " << spin << " us accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), testing::HasSubstr("spin")) << spin;
    }
  }
  // The default at 1 kHz; half the period where the asked spin is longer.
  ServoOptions o = quiet_options();
  EXPECT_DOUBLE_EQ(ServoLoop(m, d, o).spin_us(), kDefaultSpinUs);
  o.rate_hz = 4000.0;
  EXPECT_DOUBLE_EQ(ServoLoop(m, d, o).spin_us(), 125.0);
  o.rate_hz = 1000.0;
  o.spin_us = kMaxSpinUs;
  EXPECT_DOUBLE_EQ(ServoLoop(m, d, o).spin_us(), 500.0);
  o.spin_us = 0.0;
  EXPECT_DOUBLE_EQ(ServoLoop(m, d, o).spin_us(), 0.0);
}

TEST(ServoLoop, CyclesPublishSnapshotsAndTiming) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  ServoLoop loop(m, d, quiet_options());
  EXPECT_FALSE(loop.running());
  loop.start();
  EXPECT_TRUE(loop.running());
  EXPECT_THAT(loop.realtime_status(), testing::StartsWith("not requested (normal priority); "));
  if (loop.standby_cpu() >= 0) {
    EXPECT_NE(loop.cpu(), loop.standby_cpu());
    EXPECT_THAT(loop.realtime_status(),
                testing::HasSubstr("standby thread on CPU " + std::to_string(loop.standby_cpu())));
  }

  // Snapshots arrive with increasing cycle numbers and servo times one dt apart per cycle or more.
  ServoSnapshot a, b;
  ASSERT_TRUE(wait_for([&] { return loop.latest(a) && a.cycle >= 20; }));
  ASSERT_TRUE(wait_for([&] { return loop.latest(b) && b.cycle > a.cycle; }));
  EXPECT_GE(b.t - a.t, static_cast<double>(b.cycle - a.cycle) * loop.dt() - 1e-9);
  EXPECT_EQ(b.device.buttons, 5u);
  EXPECT_TRUE(b.out.graphic.finite());
  loop.stop();
  EXPECT_FALSE(loop.running());

  // Every cycle read and wrote once and was timed once; the last write was a zero wrench.
  const TimingReport r = loop.timing();
  EXPECT_GE(r.cycles, b.cycle);
  EXPECT_EQ(d.reads.load(), r.cycles);
  EXPECT_EQ(d.writes.load(), r.cycles + 1);  // + the zero wrench at stop
  EXPECT_TRUE(d.last_force.isZero());
  EXPECT_TRUE(d.last_torque.isZero());
  EXPECT_LE(r.overruns, r.cycles);
  EXPECT_GT(r.rate_hz, 0.0);
  EXPECT_LE(r.step_p50, r.step_p99);
  EXPECT_LE(r.step_p99, r.step_p999);
  EXPECT_LE(r.step_p999, r.step_max);
  EXPECT_LE(r.jitter_p50, r.jitter_max);
  EXPECT_GT(r.step_max, 0.0);
}

TEST(ServoLoop, StartStopStartContinues) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  ServoLoop loop(m, d, quiet_options());
  ServoSnapshot s;
  loop.start();
  loop.start();  // no-op while running
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.cycle >= 10; }));
  loop.stop();
  loop.stop();  // safe twice
  const uint64_t first = loop.timing().cycles;
  const double last_t = s.t;
  EXPECT_EQ(d.starts.load(), 1);
  EXPECT_EQ(d.stops.load(), 1);

  loop.start();
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.cycle >= first + 10; }));
  loop.stop();
  EXPECT_EQ(d.starts.load(), 2);
  EXPECT_EQ(d.stops.load(), 2);
  EXPECT_GT(loop.timing().cycles, first);
  EXPECT_GT(s.t, last_t);  // the servo clock continued
}

TEST(ServoLoop, SamplesFlowInOrder) {
  Model m = friction_block();
  HoldDevice d(pressing(m, 0.5));
  SpscQueue<ServoSample> queue(100000);
  ServoOptions o = quiet_options();
  o.record = &queue;
  ServoLoop loop(m, d, o);
  loop.start();
  std::vector<ServoSample> samples;
  ServoSample s;
  ASSERT_TRUE(wait_for([&] {
    while (queue.pop(s)) samples.push_back(s);
    return samples.size() >= 400;
  }));
  loop.stop();
  while (queue.pop(s)) samples.push_back(s);

  // One sample per cycle, none dropped, times increasing, the tool reached the block.
  EXPECT_EQ(loop.dropped_samples(), 0u);
  EXPECT_EQ(samples.size(), loop.timing().cycles);
  int sliding = 0;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    EXPECT_GT(samples[i].t, samples[i - 1].t);
    sliding += samples[i].state == InteractionState::Sliding;
  }
  EXPECT_GT(sliding, 0);
  EXPECT_EQ(samples.back().buttons, 5u);
  EXPECT_TRUE(samples.back().force.allFinite());
}

TEST(ServoLoop, FullRecordQueueCountsDrops) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  SpscQueue<ServoSample> queue(16);  // never drained while running
  ServoOptions o = quiet_options();
  o.record = &queue;
  ServoLoop loop(m, d, o);
  loop.start();
  ASSERT_TRUE(wait_for([&] { return loop.dropped_samples() >= 50; }));
  loop.stop();
  std::size_t kept = 0;
  ServoSample s;
  double previous = -1.0;
  while (queue.pop(s)) {
    EXPECT_GT(s.t, previous);
    previous = s.t;
    ++kept;
  }
  EXPECT_EQ(kept, 16u);
  EXPECT_EQ(loop.dropped_samples() + kept, loop.timing().cycles);
}

TEST(ServoLoop, ParamChangesReachTheModel) {
  Model m = friction_block();
  ASSERT_EQ(m.lesions.size(), 1u);
  HoldDevice d(pressing(m, 1.0));
  ServoOptions o = quiet_options();
  o.safety.ramp_time = 0.0;
  ServoLoop loop(m, d, o);
  loop.start();
  ServoSnapshot s;
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.cycle >= 5; }));

  // The starting Params are published first, as version 0, and the snapshots say so.
  PublishedParams published;
  ASSERT_TRUE(loop.latest_params(published));
  EXPECT_EQ(published.version, 0u);
  EXPECT_EQ(s.params_version, 0u);
  EXPECT_EQ(published.params.materials.size(), m.defaults.materials.size());
  EXPECT_FALSE(loop.latest_params(published));  // nothing new

  EXPECT_TRUE(loop.post(ParamChange{ParamChange::Field::MuS, 0, 0.9}));
  EXPECT_TRUE(loop.post(ParamChange{ParamChange::Field::KE, 0, 0.7}));
  EXPECT_TRUE(loop.post(ParamChange{ParamChange::Field::MuS, 3, 0.2}));  // no lesion 3: refused
  EXPECT_TRUE(loop.post(ParamChange{ParamChange::Field::ForceScale, -1, 0.5}));
  // The scale shows in the snapshots: the rendered force is half the engine's.
  ASSERT_TRUE(wait_for([&] {
    return loop.latest(s) && s.out.force.norm() > 0.05 && (s.force - 0.5 * s.out.force).norm() < 1e-9;
  }));
  ASSERT_TRUE(wait_for([&] { return loop.rejected_changes() == 1; }));

  // The applied changes are published while the loop runs: a new version the snapshots carry too.
  ASSERT_TRUE(wait_for([&] {
    loop.latest_params(published);
    return published.version > 0;
  }));
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.params_version >= published.version; }));
  loop.stop();
  loop.latest_params(published);
  int lesion_materials = 0;
  for (const Material& mat : published.params.materials) {
    if (mat.lesion != 0) continue;
    EXPECT_DOUBLE_EQ(mat.mu_s, 0.9);
    EXPECT_DOUBLE_EQ(mat.k_e, 0.7);
    ++lesion_materials;
  }
  EXPECT_GT(lesion_materials, 0);
  for (const Material& mat : m.defaults.materials) EXPECT_NE(mat.mu_s, 0.9);  // the Model never changes
}

TEST(ServoLoop, AnnouncedLimitsTightenTheParamsAndKeepTunedMaterials) {
  Model m = friction_block();
  HoldDevice d(pressing(m, 1.0));
  ServoOptions o = quiet_options();
  o.safety.ramp_time = 0.0;
  ServoLoop loop(m, d, o);
  PublishedParams published;
  ASSERT_TRUE(loop.latest_params(published));
  EXPECT_DOUBLE_EQ(published.params.limits.max_force, m.defaults.limits.max_force);
  loop.start();
  ServoSnapshot s;
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.cycle >= 5; }));

  // A tuned material, then the device announces lower limits (and a torque-free device: 0 N·mm).
  ASSERT_TRUE(loop.post(ParamChange{ParamChange::Field::MuS, 0, 0.9}));
  DeviceLimits announced;
  announced.max_force = 2.0;
  announced.max_stiffness = 0.25;
  announced.max_torque = 0.0;
  announced.workspace = Eigen::AlignedBox3d(Vec3::Constant(-50), Vec3::Constant(50));
  d.announced.write(LimitsAnnouncement{false, announced});
  ASSERT_TRUE(wait_for([&] {
    loop.latest_params(published);
    return published.params.limits.max_force == 2.0;
  }));
  ASSERT_TRUE(wait_for([&] {
    loop.latest_params(published);
    return published.params.materials[m.lesions[0].material].mu_s == 0.9;
  }));
  const Params& p = published.params;
  EXPECT_DOUBLE_EQ(p.limits.max_stiffness, 0.25);
  EXPECT_DOUBLE_EQ(p.limits.max_torque, 0.0);
  EXPECT_DOUBLE_EQ(p.gains.k_trans, 0.25);  // coupling at most the device's stiffness
  EXPECT_DOUBLE_EQ(p.limits.position_resolution, m.defaults.limits.position_resolution);
  EXPECT_TRUE(p.limits.workspace.isApprox(m.defaults.limits.workspace.intersection(announced.workspace)));
  // The rendered wrench holds them.
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.params_version >= published.version; }));
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(wait_for([&] { return loop.latest(s); }));
    EXPECT_LE(s.force.norm(), 2.0 + 1e-9);
    EXPECT_TRUE(s.torque.isZero());
  }

  // Limits no device could have are refused (the scene's apply again: TheAcknowledgement... below);
  // higher ones than the scene's are held to the scene's.
  DeviceLimits absurd = announced;
  absurd.max_force = 1e9;
  d.announced.write(LimitsAnnouncement{false, absurd});
  ASSERT_TRUE(wait_for([&] { return loop.refused_limits() == 1; }));
  DeviceLimits strong = announced;
  strong.max_force = 500.0;
  strong.max_stiffness = 50.0;
  strong.max_torque = 1e4;
  d.announced.write(LimitsAnnouncement{false, strong});
  ASSERT_TRUE(wait_for([&] {
    loop.latest_params(published);
    return published.params.limits.max_force == m.defaults.limits.max_force;
  }));
  // A cycle with those parameters, and one after it, have written their wrench to the device.
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.params_version >= published.version; }));
  ASSERT_TRUE(wait_for([&] { return loop.latest(s); }));
  loop.stop();
  EXPECT_DOUBLE_EQ(published.params.limits.max_stiffness, m.defaults.limits.max_stiffness);
  EXPECT_DOUBLE_EQ(published.params.limits.max_torque, m.defaults.limits.max_torque);
  EXPECT_DOUBLE_EQ(published.params.gains.k_trans, m.defaults.gains.k_trans);
  EXPECT_DOUBLE_EQ(published.params.materials[m.lesions[0].material].mu_s, 0.9);
  EXPECT_TRUE(d.last_status.limits_acknowledged);
  EXPECT_EQ(loop.refused_limits(), 1u);
}

TEST(ServoLoop, TheAcknowledgementIsSetExactlyWhileAnnouncedLimitsApply) {
  // Announced limits apply with the acknowledgement (wrench flag bit 15); refused ones (no device
  // renders 1e-300 N or 1e-300 N/mm: the force would be zero with no flag saying why) and withdrawn
  // ones (a new client without a hello) put the scene's limits back with the acknowledgement clear.
  // (A refused announcement once cleared the flag and kept the earlier 0.1 N; 1e-300 was accepted.)
  Model m = friction_block();
  HoldDevice d(pressing(m, 1.0));
  ServoLoop loop(m, d, quiet_options());
  loop.start();
  PublishedParams published;
  const DeviceLimits scene = m.defaults.limits;
  const auto announce = [&](double force, double stiffness) {
    DeviceLimits l;
    l.max_force = force;
    l.max_stiffness = stiffness;
    d.announced.write(LimitsAnnouncement{false, l});
  };
  const auto in_force = [&](double force, double stiffness, bool acknowledged) {
    return wait_for([&] {
      loop.latest_params(published);
      const Params& p = published.params;
      return p.limits.max_force == force && p.limits.max_stiffness == stiffness &&
             p.gains.k_trans == std::min(m.defaults.gains.k_trans, stiffness) &&
             d.acknowledged.load() == acknowledged;
    });
  };
  ParamProblem why;

  // 0.1 N and 0.01 N/mm, the smallest a device may have: in force, acknowledged.
  announce(0.1, 0.01);
  ASSERT_TRUE(in_force(0.1, 0.01, true));
  // 1e-300 N: refused, the scene's limits and coupling back, not acknowledged, the reason kept.
  announce(1e-300, 1.0);
  ASSERT_TRUE(in_force(scene.max_force, scene.max_stiffness, false));
  EXPECT_EQ(loop.refused_limits(), 1u);
  ASSERT_TRUE(loop.latest_refusal(why));
  EXPECT_STREQ(why.field, "max_force");
  EXPECT_THAT(why.rule, ::testing::HasSubstr("0.1"));
  // Again in force; then 1e-300 N/mm, refused the same way.
  announce(0.1, 0.01);
  ASSERT_TRUE(in_force(0.1, 0.01, true));
  announce(5.0, 1e-300);
  ASSERT_TRUE(in_force(scene.max_force, scene.max_stiffness, false));
  ASSERT_TRUE(loop.latest_refusal(why));
  EXPECT_STREQ(why.field, "max_stiffness");
  // A workspace that misses the scene's: refused.
  DeviceLimits far;
  far.workspace = Eigen::AlignedBox3d(Vec3::Constant(1e4), Vec3::Constant(1e4 + 1));
  announce(0.5, 0.5);
  ASSERT_TRUE(in_force(0.5, 0.5, true));
  d.announced.write(LimitsAnnouncement{false, far});
  ASSERT_TRUE(in_force(scene.max_force, scene.max_stiffness, false));
  ASSERT_TRUE(loop.latest_refusal(why));
  EXPECT_STREQ(why.field, "workspace");
  // Withdrawn: the scene's, not acknowledged, and not counted as refused.
  announce(0.5, 0.5);
  ASSERT_TRUE(in_force(0.5, 0.5, true));
  d.announced.write(LimitsAnnouncement{true, DeviceLimits{}});
  ASSERT_TRUE(in_force(scene.max_force, scene.max_stiffness, false));
  loop.stop();
  EXPECT_EQ(loop.refused_limits(), 3u);
  EXPECT_FALSE(loop.latest_refusal(why));  // nothing refused since the last look
}

TEST(ServoLoop, StartsFromGivenParamsMadeForItsModel) {
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  ServoOptions o = quiet_options();
  o.params = m.defaults;
  o.params->materials[m.lesions[0].material].mu_s = 0.42;
  ServoLoop loop(m, d, o);
  PublishedParams published;
  ASSERT_TRUE(loop.latest_params(published));
  EXPECT_DOUBLE_EQ(published.params.materials[m.lesions[0].material].mu_s, 0.42);
  o.params->materials.pop_back();  // made for another model
  try {
    ServoLoop wrong(m, d, o);
    ADD_FAILURE() << "accepted Params with another material count";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("materials"), std::string::npos) << e.what();
  }
}

TEST(ServoLoop, RunningCyclesAllocateNothing) {
  // The whole process allocates nothing while the loop runs (the test thread only reads snapshots,
  // posts changes and sleeps), with the engine sliding on the block and the recorder queue filling.
  Model m = friction_block();
  const Trajectory tr = test::press_and_slide(m, 0.5, 5.0);
  ScriptedDevice d(tr, false, "press-and-slide");
  SpscQueue<ServoSample> queue(20000);
  ServoOptions o = quiet_options();
  o.record = &queue;
  ServoLoop loop(m, d, o);
  loop.start();
  ServoSnapshot s;
  ASSERT_TRUE(
      wait_for([&] { return loop.latest(s) && s.cycle >= 400 && s.out.state == InteractionState::Sliding; }));

  const std::size_t before = test::allocation_count();
  const uint64_t cycles_before = s.cycle;
  for (int i = 0; i < 200; ++i) {
    loop.latest(s);
    loop.post(ParamChange{ParamChange::Field::MuS, 0, 0.3 + 0.001 * i});
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  while (!loop.latest(s) || s.cycle < cycles_before + 100)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const std::size_t after = test::allocation_count();
  loop.stop();

  EXPECT_EQ(after - before, 0u);
  EXPECT_GE(s.cycle, cycles_before + 100);
  EXPECT_EQ(loop.rejected_changes(), 0u);
  EXPECT_GT(s.params_version, 0u);  // the changes were applied and published inside the window
}

TEST(ServoLoop, RealtimeRequestIsAnswered) {
  // Granted or refused depends on the machine; either way the status says which.
  Model m = friction_block();
  HoldDevice d(m.tool_home);
  ServoOptions o;
  o.realtime = true;
  ServoLoop loop(m, d, o);
  loop.start();
  const std::string status = loop.realtime_status();
  ServoSnapshot s;
  ASSERT_TRUE(wait_for([&] { return loop.latest(s) && s.cycle >= 5; }));
  loop.stop();
  EXPECT_TRUE(status.rfind("SCHED_FIFO priority ", 0) == 0 || status.rfind("refused: ", 0) == 0) << status;
}

// Takes `cpu` from every thread of lower real-time priority for `stall_ms` every `every_ms`, for
// `seconds`, the way a hypervisor takes a virtual machine's core away; returns the stalls made (0 when
// real-time priority or the CPU was refused).
int take_cpu(int cpu, double seconds, int stall_ms, int every_ms) {
  if (!pin_thread(pthread_self(), {cpu}) || set_fifo_priority(pthread_self(), 95) != 0) return 0;
  using clock = std::chrono::steady_clock;
  const auto end = clock::now() + std::chrono::duration<double>(seconds);
  int stalls = 0;
  while (clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(every_ms));
    const auto until = clock::now() + std::chrono::milliseconds(stall_ms);
    while (clock::now() < until) {
    }
    ++stalls;
  }
  return stalls;
}

// Issue #11: a virtual machine's core vanishes for milliseconds dozens of times a minute
// (docs/performance.md, ninth round). A thread of higher real-time priority takes the servo thread's
// CPU for 3 ms every 50 ms. Without a standby every stall ends a cycle late; with one, the standby
// runs the cycles due meanwhile on the other CPU, and still each cycle runs once, in order. Needs two
// CPUs and SCHED_FIFO.
TEST(ServoLoop, AStandbyThreadRunsTheCyclesWhoseCoreIsTaken) {
  const std::vector<int> cpus = allowed_cpus();
  if (cpus.size() < 2) GTEST_SKIP() << "needs two CPUs";
  Model m = friction_block();
  struct Run {
    TimingReport timing;
    int stalls = 0;
    std::vector<double> t;  // s, the recorded cycles' servo times
  };
  const auto run = [&](bool standby) {
    Run out;
    HoldDevice d(pressing(m, 0.3));
    SpscQueue<ServoSample> queue(10000);
    ServoOptions o;
    o.realtime = true;
    o.standby = standby;
    o.record = &queue;
    ServoLoop loop(m, d, o);
    // Without a standby the servo thread is not pinned: it inherits this thread's CPU.
    if (!standby) pin_thread(pthread_self(), {cpus.front()});
    loop.start();
    if (!standby) pin_thread(pthread_self(), cpus);
    const int cpu = standby ? loop.cpu() : cpus.front();
    std::atomic<bool> done{false};
    std::thread hog([&] {
      out.stalls = take_cpu(cpu, 1.5, 3, 50);
      done.store(true);
    });
    ServoSample s;
    while (!done.load()) {
      while (queue.pop(s)) out.t.push_back(s.t);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    hog.join();
    loop.stop();
    while (queue.pop(s)) out.t.push_back(s.t);
    out.timing = loop.timing();
    if (loop.realtime_status().rfind("SCHED_FIFO", 0) != 0) out.stalls = 0;
    EXPECT_EQ(d.reads.load(), out.timing.cycles);
    return out;
  };
  const Run alone = run(false);
  const Run paired = run(true);
  if (alone.stalls == 0 || paired.stalls == 0) GTEST_SKIP() << "real-time priority refused";
  std::printf(
      "alone: %d stalls, %llu overruns; with the standby: %d stalls, %llu overruns, %llu standby cycles\n",
      alone.stalls, static_cast<unsigned long long>(alone.timing.overruns), paired.stalls,
      static_cast<unsigned long long>(paired.timing.overruns),
      static_cast<unsigned long long>(paired.timing.standby_cycles));

  // The stalls made the lone servo thread late; the standby ran the cycles they held up.
  EXPECT_GE(alone.timing.overruns, static_cast<uint64_t>(alone.stalls / 2)) << alone.stalls << " stalls";
  EXPECT_EQ(alone.timing.standby_cycles, 0u);
  EXPECT_GE(paired.timing.standby_cycles, static_cast<uint64_t>(paired.stalls)) << paired.stalls << " stalls";
  EXPECT_LE(paired.timing.overruns, static_cast<uint64_t>(paired.stalls / 4)) << paired.stalls << " stalls";

  // Each cycle ran once, in order: one sample each, servo times increasing by whole periods.
  ASSERT_EQ(paired.t.size(), paired.timing.cycles);
  const double dt = 1.0 / ServoOptions{}.rate_hz;
  for (std::size_t i = 1; i < paired.t.size(); ++i) {
    const double steps = (paired.t[i] - paired.t[i - 1]) / dt;
    ASSERT_GE(steps, 1.0 - 1e-6) << i;
    ASSERT_NEAR(steps, std::round(steps), 1e-6) << i;
  }
}

}  // namespace
}  // namespace cariesim
