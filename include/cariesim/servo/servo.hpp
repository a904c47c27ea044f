#pragma once
/// The real-time servo loop (docs/design.md §5): a thread stepping the haptic engine at a fixed rate with
/// absolute deadlines, reading a device, filtering the wrench through ForceSafety and writing it back.
/// It shares no lock with anyone: the latest state and the running Params go out through
/// TripleBuffers, parameter changes come in through an SpscQueue, samples go to the recorder through
/// another SpscQueue. Session (servo/session.hpp) builds a loop with its device and recorder.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/common/lockfree.hpp"
#include "cariesim/device/device.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/record/sample.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/render/step.hpp"

namespace cariesim {

/// Step time and loop jitter, as a fixed-bin histogram (allocation-free to fill). One thread adds;
/// any thread may read at the same time (the bins are atomics: a reading taken while values are
/// being added is approximate, never torn).
class TimingHistogram {
 public:
  static constexpr int kFineBins = 4096;     ///< 0.25 µs bins from 0 to 1024 µs
  static constexpr double kFineUs = 0.25;    ///< µs, width of a fine bin
  static constexpr int kCoarseBins = 1008;   ///< 64 µs bins from 1024 µs to 65536 µs (overruns)
  static constexpr double kCoarseUs = 64.0;  ///< µs, width of a coarse bin
  static constexpr int kBins = kFineBins + kCoarseBins + 1;  ///< the last bin holds the rest
  TimingHistogram() = default;
  TimingHistogram(const TimingHistogram& other) { *this = other; }
  TimingHistogram& operator=(const TimingHistogram& other);
  /// Adds one value (µs; negative and non-finite values count as 0). One writer thread.
  void add(double us);
  /// The value below which a fraction `p` (in [0, 1], e.g. 0.999) of the values lie: µs, the upper
  /// edge of its bin, never above max(); 0 when empty.
  [[nodiscard]] double percentile(double p) const;
  [[nodiscard]] double max() const { return max_.load(std::memory_order_relaxed); }  ///< µs
  [[nodiscard]] uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  /// Empties it (not while another thread adds).
  void reset();

 private:
  std::array<std::atomic<uint64_t>, kBins> bins_{};
  std::atomic<uint64_t> count_{0};
  std::atomic<double> max_{0.0};
};

/// Timing of a loop. "Step" is one cycle's work from wake-up to the device write: device read,
/// parameter changes, engine step, safety; "jitter" is how late the thread woke up after its deadline. An
/// overrun is a cycle whose work ended after the next deadline.
struct TimingReport {
  double step_p50 = 0, step_p99 = 0, step_p999 = 0, step_max = 0;          ///< µs
  double jitter_p50 = 0, jitter_p99 = 0, jitter_p999 = 0, jitter_max = 0;  ///< µs, wake-up lateness
  uint64_t cycles = 0;
  uint64_t overruns = 0;
  uint64_t work_budget = 0;  ///< steps the work budget cut short (kFlagWorkBudget)
  uint64_t standby_cycles = 0;  ///< cycles the standby thread ran (ServoOptions::standby)
  double rate_hz = 0.0;  ///< measured
};

/// What the servo thread publishes every cycle for the viewer.
struct ServoSnapshot {
  StepOutput out;
  DeviceState device;
  Vec3 force = Vec3::Zero();   ///< N, rendered
  Vec3 torque = Vec3::Zero();  ///< N·mm, rendered
  uint32_t safety_flags = 0;
  double t = 0.0;  ///< s since start
  uint64_t cycle = 0;
  uint64_t overruns = 0;
  uint64_t work_budget = 0;    ///< steps so far the work budget cut short (kFlagWorkBudget)
  double rate_hz = 0.0;        ///< measured over the last second
  uint64_t safety_faults = 0;  ///< cycles whose force ForceSafety zeroed, so far
  /// Version of the running Params: 0 as the loop started, +1 whenever a change applied or the
  /// device's announced limits tightened them (ServoLoop::latest_params hands out that version).
  uint64_t params_version = 0;
};

/// The running Params as the servo thread published them.
struct PublishedParams {
  Params params;         ///< materials, coupling gains, device limits in force
  uint64_t version = 0;  ///< ServoSnapshot::params_version they belong to
};

/// µs, ServoOptions::spin_us unless asked otherwise.
inline constexpr double kDefaultSpinUs = 150.0;
/// µs, the longest spin accepted (the effective one is also at most half the period).
inline constexpr double kMaxSpinUs = 10000.0;

/// The graphic tool taken by the servo thread at given servo times: a window playing an answers
/// file marks at each mark's servo time with the tip of that cycle, as `cariesim study run` takes it
/// from the recording (docs/viewer.md "Automation"), however late the window draws.
///
/// The times are fixed at construction (the storage too): the servo thread fills the entries in time
/// order (take(), no allocation, no lock) and publishes how many with release; the owner reads an
/// entry once taken() passed it.
class TimedCapture {
 public:
  /// One capture: the first cycle at or after its time.
  struct Entry {
    double t = 0.0;  ///< s, servo time of the cycle that took it
    Pose graphic;    ///< the graphic tool then (its origin is the tip)
    int contacts = 0;
  };
  /// `times` (s, servo time) in any order; they are taken in ascending order (times()).
  explicit TimedCapture(std::vector<double> times);
  /// Servo thread: takes every time at or before `t` (s) not taken yet.
  void take(double t, const Pose& graphic, int contacts) noexcept;
  /// How many times (in ascending order) are taken; any thread.
  [[nodiscard]] std::size_t taken() const { return taken_.load(std::memory_order_acquire); }
  /// The times, ascending.
  [[nodiscard]] const std::vector<double>& times() const { return times_; }
  /// Entry i (i < taken()).
  [[nodiscard]] const Entry& entry(std::size_t i) const { return entries_[i]; }

 private:
  std::vector<double> times_;
  std::vector<Entry> entries_;
  std::atomic<std::size_t> taken_{0};
};

struct ServoOptions {
  double rate_hz = 1000.0;                   ///< Hz, 1 kHz default, up to 10 kHz
  bool realtime = true;                      ///< ask for SCHED_FIFO (reports when refused)
  int realtime_priority = 80;                ///< SCHED_FIFO priority asked for (1-99)
  /// µs before each deadline the thread stops sleeping and polls the clock (wait_until_ns), at most
  /// half the period; 0 sleeps the whole wait. Costs that share of a core; buys a punctual start
  /// (a sleeping thread may wake up to 0.5 ms late; docs/performance.md).
  double spin_us = kDefaultSpinUs;
  /// A second servo thread on another core that runs a cycle the first has not started a quarter
  /// period after its deadline. On a virtual machine the hypervisor takes a core away
  /// for 0.2-5 ms dozens of times a minute, whatever runs on it; a thread asleep or polling there
  /// then wakes too late, while the other core usually runs on. With it the two threads are pinned
  /// to two CPUs of the process's affinity (none when it has only one: the standby is then off, as
  /// realtime_status() says). The standby sleeps between its checks (no polling).
  bool standby = true;
  SafetyParams safety;                       ///< ramp and global force scale
  SpscQueue<ServoSample>* record = nullptr;  ///< where samples go (the recorder's queue), optional
  TimedCapture* capture = nullptr;           ///< poses to take at given servo times, optional
  /// The Params to start from (e.g. a restarted session's, with what the user tuned); their material
  /// count must be the model's. Default: initial_params(model, device limits).
  std::optional<Params> params;
};

/// Hz, the fastest servo rate.
inline constexpr double kMaxServoRate = 10000.0;
/// Throws cariesim::Error when `rate_hz` is outside (0, kMaxServoRate].
void check_servo_rate(double rate_hz);
/// Throws cariesim::Error when `spin_us` is outside [0, kMaxSpinUs] or not a number.
void check_servo_spin(double spin_us);

/// The Params a loop starts from: the model's authored ones (Model::defaults) within the limits of
/// a device (with_device_limits: the tighter limits, the coupling stiffness at most the device's).
Params initial_params(const Model& model, const DeviceLimits& device);

/// The servo thread. Per cycle, at absolute deadlines (CLOCK_MONOTONIC, TIMER_ABSTIME) spaced by the
/// fixed period 1/rate_hz: read the device, apply queued parameter changes and limits the device
/// announced (its Params), step the engine with dt = 1/rate_hz (never the measured delta), filter
/// the wrench through ForceSafety, write it to the device, publish a snapshot (and the Params when
/// they changed), push a sample. The step's input guard judges each reading against the model's
/// InputLimits (Model::settings.input): one that is invalid or not finite is replaced by the last
/// good pose, and on any fault (also a stale reading or a jump) the safety layer zeroes the force.
/// The cycle allocates nothing, takes no lock and does no I/O. When the loop falls more than a
/// period behind, it skips the missed deadlines instead of running them back to back (the servo
/// clock follows the wall clock).
///
/// With ServoOptions::standby a second thread on another CPU runs any cycle the servo thread has not
/// claimed a quarter period after its deadline. Cycles are claimed one at a time through one atomic
/// (compare-exchange, no lock), so each runs once, in order, on one thread; the loop's data passes
/// between the two with a happens-before. The device, the snapshot buffer and the sample queue keep a
/// single user at a time.
///
/// A device whose SDK owns the servo thread (Device::clock(), e.g. OpenHaptics' scheduler) clocks the
/// loop instead: start() starts no thread of its own, and each tick of the device's clock runs one
/// cycle on the device's thread, with dt the device's period (servo time advances by dt per tick) and
/// the same safety, snapshot, samples and timing report (jitter: how much later than one period after
/// the previous tick a tick came). ServoOptions::rate_hz, spin_us and standby do not apply then.
///
/// Limits: the step clamps the wrench to Params::limits (the one clamp). They start as the scene's
/// within the device's (initial_params); when the device announces limits (Device::poll_limits) and
/// check_limits accepts them, they become the scene's within the announced ones, the coupling
/// stiffness at most the new maximum stiffness (eq. 6's k_p is that maximum); the materials, with
/// whatever the user changed, stay. Announced limits that check_limits refuses, or that the device
/// withdraws (a new client without a hello), put the scene's limits and coupling back; the status
/// the device gets (DeviceStatus::limits_acknowledged) is true exactly while announced limits apply.
class ServoLoop {
 public:
  /// The loop owns a State for `model` and the running Params (options.params, or the model's
  /// defaults within the device's limits; changes arrive through post()); `model` and `device` must
  /// outlive it. Throws cariesim::Error when rate_hz is outside (0, 10000], spin_us outside
  /// [0, 10000] or options.params were made for another model.
  ServoLoop(const Model& model, Device& device, const ServoOptions& options);
  ~ServoLoop();
  ServoLoop(const ServoLoop&) = delete;
  ServoLoop& operator=(const ServoLoop&) = delete;

  /// Starts the device (Device::start) and the thread; the servo clock continues where the last run
  /// stopped and the force ramps in again. Throws what the device throws. No-op when running.
  void start();
  /// Stops the thread, then the device. Safe to call twice.
  void stop();
  [[nodiscard]] bool running() const { return running_.load(); }
  /// "SCHED_FIFO priority N" or why real-time priority was refused (set by start()).
  [[nodiscard]] std::string realtime_status() const;
  /// The latest snapshot, if a new one was published since the last call (one reader thread).
  bool latest(ServoSnapshot& out) { return snapshots_.read(out); }
  /// Queues a parameter change (one producer thread); false when the queue is full.
  bool post(const ParamChange& change) { return changes_.push(change); }
  /// Timing so far, over every run (exact after stop(); approximate while running). Any thread.
  [[nodiscard]] TimingReport timing() const;
  /// Samples that did not fit in the record queue.
  [[nodiscard]] uint64_t dropped_samples() const { return dropped_.load(); }
  /// Parameter changes that did not apply (apply_param_change returned false).
  [[nodiscard]] uint64_t rejected_changes() const { return rejected_changes_.load(); }
  /// Device limit announcements refused (check_limits found a problem).
  [[nodiscard]] uint64_t refused_limits() const { return refused_limits_.load(); }
  /// Why the last refused announcement was refused (the field and the rule it broke), if one was
  /// refused since the last call (one reader thread).
  bool latest_refusal(ParamProblem& out) { return refusals_.read(out); }
  /// The running Params, if the servo thread published a new version since the last call (one
  /// reader thread; the first call after construction always gets the starting ones).
  bool latest_params(PublishedParams& out) { return params_out_.read(out); }
  /// The fixed step, 1 / rate_hz (s); with a device's clock, its period (after start()).
  [[nodiscard]] double dt() const { return dt_; }
  /// µs polled before each deadline: ServoOptions::spin_us, at most half the period.
  [[nodiscard]] double spin_us() const { return static_cast<double>(spin_ns_) * 1e-3; }
  /// The CPUs the servo thread and its standby are pinned to while running (-1: not pinned, or no
  /// standby).
  [[nodiscard]] int cpu() const { return cpus_[0]; }
  [[nodiscard]] int standby_cpu() const { return cpus_[1]; }

 private:
  /// One servo thread's loop: the primary (role 0) waits for each deadline, the standby (role 1) a
  /// quarter period longer; whichever claims a cycle first runs it (next_cycle_).
  void run(int role);
  /// One cycle at servo time `t` (s) for the deadline `deadline_ns`, woken at `wake_ns`
  /// (CLOCK_MONOTONIC ns). Returns when the work ended (before publishing).
  int64_t cycle(double t, int64_t deadline_ns, int64_t wake_ns);
  /// The period and dt of a loop at `rate_hz` (its own clock's or the device's).
  void set_period(double rate_hz);
  /// Starts a loop clocked by the device (DeviceClock), and its tick.
  void start_clocked();
  static void clock_tick(void* context);
  void tick();
  /// Applies queued changes and announced limits to params_; true when they changed. Servo thread.
  bool update_params();
  const Model& model_;
  Device& device_;
  PublishedParams params_;  // the running Params and their version; servo thread only while running
  ServoOptions options_;
  double dt_;  // s
  int64_t period_ns_;
  int64_t spin_ns_;  // the polled end of each wait: options.spin_us, at most half the period
  DeviceClock* clock_ = nullptr;  // the device's clock while it clocks the loop, else null
  uint64_t clock_cycles_ = 0;     // ticks of the device's clock in this run
  int64_t last_tick_ns_ = 0;      // CLOCK_MONOTONIC ns of the last tick (0: none yet)
  std::unique_ptr<State> state_;
  ForceSafety safety_;
  TripleBuffer<ServoSnapshot> snapshots_;
  TripleBuffer<PublishedParams> params_out_;  // slots sized for the model's materials at construction
  TripleBuffer<ParamProblem> refusals_;       // why device limits were refused, servo -> any one reader
  SpscQueue<ParamChange> changes_{256};
  std::thread thread_, standby_thread_;
  std::atomic<bool> running_{false};
  // The next cycle to run, by its index on the deadline grid (deadline = start_ns_ + index * period);
  // kCycleBusy is set while a thread runs it. Claimed by compare-exchange, handed on with release, so
  // the cycle's data (state, safety, device, snapshots, samples) passes from one thread to the other
  // with a happens-before and is never touched by both at once.
  static constexpr uint64_t kCycleBusy = uint64_t{1} << 63;
  std::atomic<uint64_t> next_cycle_{0};
  int64_t start_ns_ = 0;       // CLOCK_MONOTONIC ns, the grid's origin for this run
  double last_t_ = 0.0;        // s, servo time of the last cycle run
  double elapsed_base_ = 0.0;  // s, elapsed_ when this run started
  std::array<int, 2> cpus_{-1, -1};
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> rejected_changes_{0};
  std::atomic<uint64_t> refused_limits_{0};
  std::string realtime_status_;
  TimingHistogram step_hist_, jitter_hist_;
  std::atomic<uint64_t> cycles_{0}, overruns_{0}, work_budget_{0}, standby_cycles_{0};
  std::atomic<double> elapsed_{0.0};  // s, wall time run by the loop over every run
  double time_base_ = 0.0;            // s, servo time at which the current run started
  // The thread running the cycle only.
  ServoSnapshot snapshot_;
  bool limits_announced_ = false;  // the device announced limits and they are in force
  int64_t rate_mark_ns_ = 0;
  uint64_t rate_mark_cycles_ = 0;
  double measured_rate_ = 0.0;
};

}  // namespace cariesim
