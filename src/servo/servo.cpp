#include "cariesim/servo/servo.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <utility>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/cpu.hpp"
#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

constexpr int kMaxChangesPerCycle = 32;  // parameter changes applied between two steps, at most

// Single-writer increment of an atomic counter (no read-modify-write needed).
void bump(std::atomic<uint64_t>& counter) {
  counter.store(counter.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

// The bridge protocol's state byte (DeviceStatus::state) of an interaction state.
uint8_t state_code(InteractionState state) {
  switch (state) {
    case InteractionState::Free:
      return 0;
    case InteractionState::Sliding:
      return 1;
    case InteractionState::Inserting:
      return 2;
    case InteractionState::Extracting:
      return 3;
  }
  return 0;
}

// The running Params a loop starts with: the given ones, checked against the model, or its own.
PublishedParams starting_params(const Model& model, Device& device, const ServoOptions& options) {
  PublishedParams p;
  p.params = options.params ? *options.params : initial_params(model, device.info().limits);
  if (p.params.materials.size() != model.defaults.materials.size())
    throw Error("servo: the starting Params hold " + std::to_string(p.params.materials.size()) +
                " materials, the model " + std::to_string(model.defaults.materials.size()));
  return p;
}

}  // namespace

void check_servo_rate(double rate_hz) {
  if (!(rate_hz > 0.0 && rate_hz <= kMaxServoRate))
    throw Error("servo rate " + std::to_string(rate_hz) + " Hz is outside (0, 10000]");
}

void check_servo_spin(double spin_us) {
  if (!(spin_us >= 0.0 && spin_us <= kMaxSpinUs))
    throw Error("servo spin " + std::to_string(spin_us) + " us is outside [0, " +
                std::to_string(static_cast<int>(kMaxSpinUs)) + "]");
}

Params initial_params(const Model& model, const DeviceLimits& device) {
  return with_device_limits(model.defaults, device);
}

TimingHistogram& TimingHistogram::operator=(const TimingHistogram& other) {
  if (this == &other) return *this;
  for (int b = 0; b < kBins; ++b)
    bins_[b].store(other.bins_[b].load(std::memory_order_relaxed), std::memory_order_relaxed);
  count_.store(other.count(), std::memory_order_relaxed);
  max_.store(other.max(), std::memory_order_relaxed);
  return *this;
}

void TimingHistogram::add(double us) {
  if (!(us >= 0.0)) us = 0.0;  // negative or NaN
  // Fine bins up to 1024 µs, coarse ones up to 65.5 ms, then the overflow bin.
  const double fine_top = kFineBins * kFineUs;
  int bin = kBins - 1;
  if (us < fine_top) {
    bin = std::min(static_cast<int>(us / kFineUs), kFineBins - 1);
  } else if (us < fine_top + kCoarseBins * kCoarseUs) {
    bin = kFineBins + std::min(static_cast<int>((us - fine_top) / kCoarseUs), kCoarseBins - 1);
  }
  bins_[bin].store(bins_[bin].load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  if (us > max_.load(std::memory_order_relaxed)) max_.store(us, std::memory_order_relaxed);
}

double TimingHistogram::percentile(double p) const {
  // Count what the bins hold now (self-consistent even while another thread adds).
  uint64_t n = 0;
  for (const auto& b : bins_) n += b.load(std::memory_order_relaxed);
  if (n == 0) return 0.0;
  const double fraction = std::isfinite(p) ? std::clamp(p, 0.0, 1.0) : 1.0;
  const auto target =
      std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(fraction * static_cast<double>(n))));
  const double top = max();
  uint64_t cumulative = 0;
  for (int b = 0; b < kBins - 1; ++b) {
    cumulative += bins_[b].load(std::memory_order_relaxed);
    if (cumulative >= target) {
      const double upper_edge =
          b < kFineBins ? (b + 1) * kFineUs : kFineBins * kFineUs + (b - kFineBins + 1) * kCoarseUs;
      return std::min(upper_edge, top);
    }
  }
  return top;  // the overflow bin: its values are only bounded by the maximum
}

void TimingHistogram::reset() {
  for (auto& b : bins_) b.store(0, std::memory_order_relaxed);
  count_.store(0, std::memory_order_relaxed);
  max_.store(0.0, std::memory_order_relaxed);
}

ServoLoop::ServoLoop(const Model& model, Device& device, const ServoOptions& options)
    : model_(model),
      device_(device),
      params_(starting_params(model, device, options)),
      options_(options),
      dt_(0.0),
      period_ns_(0),
      spin_ns_(0),
      safety_(options.safety),
      params_out_(params_) {
  check_servo_rate(options.rate_hz);
  check_servo_spin(options.spin_us);
  set_period(options.rate_hz);
  spin_ns_ = std::min<int64_t>(std::llround(options.spin_us * 1e3), period_ns_ / 2);
  options_.params.reset();  // held in params_
  // The starting Params are published at once; later versions reuse the slots' memory.
  params_out_.write(params_);
  state_ = std::make_unique<State>(model, model.tool_home);
}

ServoLoop::~ServoLoop() { stop(); }

void ServoLoop::set_period(double rate_hz) {
  period_ns_ = std::max<int64_t>(1, std::llround(1e9 / rate_hz));
  dt_ = static_cast<double>(period_ns_) * 1e-9;
}

void ServoLoop::start() {
  if (running_.load()) return;
  device_.start();
  safety_.reset();
  // The deadline grid starts now; the servo clock continues where the last run stopped.
  start_ns_ = monotonic_ns();
  elapsed_base_ = elapsed_.load(std::memory_order_relaxed);
  last_t_ = time_base_ - dt_;
  rate_mark_ns_ = start_ns_;
  rate_mark_cycles_ = cycles_.load(std::memory_order_relaxed);
  measured_rate_ = options_.rate_hz;
  next_cycle_.store(0, std::memory_order_relaxed);
  // A device whose SDK owns the servo thread clocks the loop: each of its ticks runs one cycle, at
  // the device's rate (dt is its period), on its thread.
  clock_ = device_.clock();
  if (clock_ != nullptr) {
    start_clocked();
    return;
  }
  set_period(options_.rate_hz);
  // With a standby: the servo thread on the highest CPU of the process's affinity, the standby on the
  // next; with only one CPU, no standby.
  const std::vector<int> allowed = options_.standby ? allowed_cpus() : std::vector<int>{};
  cpus_ = allowed.size() >= 2 ? std::array<int, 2>{allowed[0], allowed[1]} : std::array<int, 2>{-1, -1};
  running_.store(true);
  thread_ = std::thread([this] { run(0); });
  if (cpus_[1] >= 0) standby_thread_ = std::thread([this] { run(1); });

  // Each thread on its own CPU (with a standby), at real-time priority when asked; say what happened.
  std::string cpus;
  if (cpus_[1] >= 0) {
    const bool pinned = pin_thread(thread_.native_handle(), {cpus_[0]}) &&
                        pin_thread(standby_thread_.native_handle(), {cpus_[1]});
    cpus = "; standby thread on CPU " + std::to_string(cpus_[1]) + ", servo thread on CPU " +
           std::to_string(cpus_[0]) + (pinned ? "" : " (pinning refused)");
  } else {
    cpus = options_.standby ? "; no standby thread (one CPU)" : "; no standby thread";
  }
  if (!options_.realtime) {
    realtime_status_ = "not requested (normal priority)" + cpus;
    return;
  }
  int rc = set_fifo_priority(thread_.native_handle(), options_.realtime_priority);
  if (rc == 0 && standby_thread_.joinable())
    rc = set_fifo_priority(standby_thread_.native_handle(), options_.realtime_priority);
  if (rc == 0) {
    realtime_status_ =
        "SCHED_FIFO priority " + std::to_string(clamp_fifo_priority(options_.realtime_priority)) + cpus;
  } else {
    realtime_status_ = std::string("refused: ") + std::strerror(rc) +
                       " (needs CAP_SYS_NICE or an rtprio limit); normal priority" + cpus;
    spdlog::warn("servo: real-time priority {}", realtime_status_);
  }
}

void ServoLoop::start_clocked() {
  const double rate = clock_->rate_hz();
  try {
    check_servo_rate(rate);
  } catch (const Error& e) {
    device_.stop();
    throw Error(std::string("the device's servo clock: ") + e.what());
  }
  set_period(rate);
  measured_rate_ = rate;
  clock_cycles_ = 0;
  last_tick_ns_ = 0;
  cpus_ = {-1, -1};
  running_.store(true);
  try {
    clock_->start_clock(&ServoLoop::clock_tick, this);
  } catch (...) {
    running_.store(false);
    device_.stop();
    throw;
  }
  realtime_status_ = "clocked by the device's scheduler at " + std::to_string(std::lround(rate)) +
                     " Hz (its thread and priority)";
}

void ServoLoop::clock_tick(void* context) {
  auto* loop = static_cast<ServoLoop*>(context);
  if (loop->running_.load(std::memory_order_acquire)) loop->tick();
}

void ServoLoop::tick() {
  // One cycle per tick of the device's clock: servo time advances by the fixed dt per tick; the
  // jitter is how much later than one period after the previous tick this one came.
  const int64_t wake = monotonic_ns();
  const int64_t expected = last_tick_ns_ > 0 ? last_tick_ns_ + period_ns_ : wake;
  jitter_hist_.add(static_cast<double>(std::max<int64_t>(0, wake - expected)) * 1e-3);
  last_tick_ns_ = wake;
  const double t = time_base_ + static_cast<double>(clock_cycles_++) * dt_;
  const int64_t end = cycle(t, wake, wake);
  last_t_ = t;
  elapsed_.store(elapsed_base_ + static_cast<double>(end - start_ns_) * 1e-9, std::memory_order_relaxed);
}

void ServoLoop::stop() {
  if (!running_.exchange(false)) return;
  if (clock_ != nullptr) {
    clock_->stop_clock();  // returns once the last tick has finished
  } else {
    thread_.join();
    if (standby_thread_.joinable()) standby_thread_.join();
  }
  // Leave the device with no force, and continue the servo clock at the next start.
  device_.set_status(
      DeviceStatus{state_code(state_->interaction()), state_->depth(), 0, 0, limits_announced_});
  device_.write(Vec3::Zero(), Vec3::Zero());
  time_base_ = last_t_ + dt_;
  device_.stop();
}

std::string ServoLoop::realtime_status() const { return realtime_status_; }

TimingReport ServoLoop::timing() const {
  TimingReport r;
  r.step_p50 = step_hist_.percentile(0.5);
  r.step_p99 = step_hist_.percentile(0.99);
  r.step_p999 = step_hist_.percentile(0.999);
  r.step_max = step_hist_.max();
  r.jitter_p50 = jitter_hist_.percentile(0.5);
  r.jitter_p99 = jitter_hist_.percentile(0.99);
  r.jitter_p999 = jitter_hist_.percentile(0.999);
  r.jitter_max = jitter_hist_.max();
  r.cycles = cycles_.load();
  r.overruns = overruns_.load();
  r.work_budget = work_budget_.load();
  r.standby_cycles = standby_cycles_.load();
  const double elapsed = elapsed_.load();
  r.rate_hz = elapsed > 0.0 ? static_cast<double>(r.cycles) / elapsed : 0.0;
  return r;
}

void ServoLoop::run(int role) {
  // The servo thread (role 0) waits for each deadline, polling the clock for its last spin_ns_. The
  // standby (role 1) sleeps to a quarter period after it and runs the cycle only if the servo thread
  // has not claimed it by then: the hypervisor took its core away, or it was woken late.
  const int64_t delay = role == 0 ? 0 : period_ns_ / 4;
  const int64_t spin = role == 0 ? spin_ns_ : 0;
  const auto deadline_of = [&](uint64_t index) {
    return start_ns_ + static_cast<int64_t>(index) * period_ns_;
  };
  while (running_.load(std::memory_order_relaxed)) {
    const uint64_t seen = next_cycle_.load(std::memory_order_acquire);
    if ((seen & kCycleBusy) != 0) {
      // A cycle is under way on the other thread: look again when the next one is due, or a quarter
      // period from now when it is due already (the cycle under way has overrun).
      const int64_t due = deadline_of((seen & ~kCycleBusy) + 1) + delay;
      const int64_t now = monotonic_ns();
      if (due > now)
        wait_until_ns(due, spin);
      else
        sleep_until_ns(now + period_ns_ / 4);
      continue;
    }
    const int64_t deadline = deadline_of(seen);
    wait_until_ns(deadline + delay, spin);
    uint64_t expected = seen;
    if (!next_cycle_.compare_exchange_strong(expected, seen | kCycleBusy, std::memory_order_acq_rel,
                                             std::memory_order_relaxed))
      continue;  // the other thread claimed it first
    // How late the cycle starts after its deadline is the jitter.
    const int64_t wake = monotonic_ns();
    jitter_hist_.add(static_cast<double>(wake - deadline) * 1e-3);
    if (role != 0) bump(standby_cycles_);
    const double t = time_base_ + static_cast<double>(deadline - start_ns_) * 1e-9;
    const int64_t end = cycle(t, deadline, wake);
    last_t_ = t;
    elapsed_.store(elapsed_base_ + static_cast<double>(end - start_ns_) * 1e-9, std::memory_order_relaxed);

    // The next deadline, one fixed period on; skip the ones already missed by more than a period.
    int64_t next = deadline + period_ns_;
    if (end - next > period_ns_) next += (end - next) / period_ns_ * period_ns_;
    next_cycle_.store(static_cast<uint64_t>((next - start_ns_) / period_ns_), std::memory_order_release);
  }
}

bool ServoLoop::update_params() {
  // Parameter changes queued by the UI, applied between two steps.
  bool changed = false;
  ParamChange change;
  for (int i = 0; i < kMaxChangesPerCycle && changes_.pop(change); ++i) {
    bool applied = false;
    if (change.field == ParamChange::Field::ForceScale) {
      applied = std::isfinite(change.value) && change.value >= 0.0 && change.value <= 1.0;
      if (applied) safety_.set_force_scale(change.value);
    } else {
      applied = apply_param_change(params_.params, change);
      changed = changed || applied;
    }
    if (!applied) bump(rejected_changes_);
  }

  // What the device said about its limits. Announced limits are checked (a device that renders no
  // torque announces 0); accepted, the scene's within them are in force, the coupling stiffness no
  // higher than the new maximum (eq. 6's k_p), the materials keeping what the user changed. Refused
  // (with the reason kept for the report) or withdrawn (a new client without a hello), the scene's
  // limits are in force again: the acknowledgement (wrench flag bit 15) is set exactly while an
  // announcement's limits apply.
  LimitsAnnouncement news;
  if (device_.poll_limits(news)) {
    DeviceLimits checked = news.limits;
    if (checked.max_torque == 0.0) checked.max_torque = kMaxDeviceTorque;
    const DeviceLimits limits = tighter(model_.defaults.limits, news.limits);
    ParamProblem problem;
    if (!news.withdrawn) {
      problem = check_limits(checked);
      if (!problem && limits.workspace.isEmpty())
        problem = {"workspace", "must overlap the scene's workspace"};
      if (problem) {
        bump(refused_limits_);
        refusals_.write(problem);
      }
    }
    const bool announced = !news.withdrawn && !problem;
    const DeviceLimits& next = announced ? limits : model_.defaults.limits;
    const double k_trans = std::min(model_.defaults.gains.k_trans, next.max_stiffness);
    DeviceLimits& now = params_.params.limits;
    const bool differ =
        now.max_force != next.max_force || now.max_stiffness != next.max_stiffness ||
        now.max_torque != next.max_torque || now.position_resolution != next.position_resolution ||
        now.workspace.min() != next.workspace.min() || now.workspace.max() != next.workspace.max() ||
        params_.params.gains.k_trans != k_trans;
    if (differ) {
      now = next;
      params_.params.gains.k_trans = k_trans;
      changed = true;
    }
    limits_announced_ = announced;
  }
  return changed;
}

TimedCapture::TimedCapture(std::vector<double> times) : times_(std::move(times)), entries_(times_.size()) {
  std::sort(times_.begin(), times_.end());
}

void TimedCapture::take(double t, const Pose& graphic, int contacts) noexcept {
  // Every time reached, in order; the count is published after the entries are written.
  std::size_t n = taken_.load(std::memory_order_relaxed);
  const std::size_t before = n;
  while (n < times_.size() && times_[n] <= t) entries_[n++] = Entry{t, graphic, contacts};
  if (n != before) taken_.store(n, std::memory_order_release);
}

int64_t ServoLoop::cycle(double t, int64_t deadline_ns, int64_t wake_ns) {
  // Read the device. The step's input guard judges the reading (an unusable one is replaced by the
  // last good pose) and safety acts on its verdict.
  const DeviceState input = device_.read(t);

  // Changes and announced limits, after the reading: limits a device announced before the pose it
  // sent are in force for that pose's wrench. A new version of the Params is published (into the
  // buffer's reserved slots).
  if (update_params()) {
    ++params_.version;
    params_out_.write(params_);
  }

  // Step the engine with the fixed dt (its output stage clamps the wrench to the Params' limits),
  // filter the wrench, render it. The device's status carries the step's clamp beside what the safety
  // layer did.
  const StepOutput out =
      step(model_, params_.params, *state_, HapticInput{input.pose, dt_, input.valid, t - input.stamp});
  Vec3 force = out.force;
  Vec3 torque = out.torque;
  safety_.filter(force, torque, out.input_faults, t);
  const uint32_t safety_flags = safety_.flags();
  device_.set_status(DeviceStatus{state_code(out.state), out.depth, safety_flags, out.flags,
                                  limits_announced_, (out.flags & kFlagForceClamped) != 0,
                                  (out.flags & kFlagTorqueClamped) != 0});
  device_.write(force, torque);

  // Timing of this cycle's work; an overrun ended after the next deadline.
  const int64_t end = monotonic_ns();
  const double work_us = static_cast<double>(end - wake_ns) * 1e-3;
  step_hist_.add(work_us);
  const bool overrun = end > deadline_ns + period_ns_;
  if (overrun) bump(overruns_);
  if ((out.flags & kFlagWorkBudget) != 0) bump(work_budget_);
  bump(cycles_);
  const uint64_t cycles = cycles_.load(std::memory_order_relaxed);
  if (wake_ns - rate_mark_ns_ >= 1000000000) {
    measured_rate_ =
        static_cast<double>(cycles - rate_mark_cycles_) * 1e9 / static_cast<double>(wake_ns - rate_mark_ns_);
    rate_mark_ns_ = wake_ns;
    rate_mark_cycles_ = cycles;
  }

  // Poses asked for at this servo time (TimedCapture), taken before the snapshot that shows the time.
  if (options_.capture != nullptr) options_.capture->take(t, out.graphic, out.contacts);

  // Publish the snapshot for the viewer.
  snapshot_.out = out;
  snapshot_.device = input;
  snapshot_.force = force;
  snapshot_.torque = torque;
  snapshot_.safety_flags = safety_flags;
  snapshot_.t = t;
  snapshot_.cycle = cycles;
  snapshot_.overruns = overruns_.load(std::memory_order_relaxed);
  snapshot_.work_budget = work_budget_.load(std::memory_order_relaxed);
  snapshot_.rate_hz = measured_rate_;
  snapshot_.safety_faults = safety_.faults();
  snapshot_.params_version = params_.version;
  snapshots_.write(snapshot_);

  // The sample for the recorder; dropped (and counted) when its queue is full.
  if (options_.record != nullptr) {
    ServoSample s;
    s.t = t;
    s.haptic = out.haptic;
    s.graphic = out.graphic;
    s.force = force;
    s.torque = torque;
    s.depth = static_cast<float>(out.depth);
    s.step_us = static_cast<float>(out.step_us);
    s.soft_tissue_force = static_cast<float>(out.soft_tissue_force);
    s.step_flags = out.flags;
    s.safety_flags = safety_flags;
    s.contacts = static_cast<uint16_t>(std::clamp(out.contacts, 0, 65535));
    s.lesion = static_cast<int8_t>(std::clamp(out.lesion, -1, 127));
    s.state = out.state;
    s.overrun = overrun;
    s.buttons = input.buttons;
    if (!options_.record->push(s)) bump(dropped_);
  }
  return end;
}

}  // namespace cariesim
