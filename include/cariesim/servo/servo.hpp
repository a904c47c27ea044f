#pragma once
/// The real-time servo loop (DESIGN.md §5): a thread stepping the haptic engine at a fixed rate with
/// absolute deadlines, reading a device, filtering the wrench through ForceSafety and writing it back.
/// It shares no lock with anyone: the latest state goes out through a TripleBuffer, parameter changes
/// come in through an SpscQueue, samples go to the recorder through another SpscQueue.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "cariesim/device/device.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/servo/lockfree.hpp"

namespace cariesim {

/// A parameter change from the UI, applied by the servo thread between two steps.
struct ParamChange {
  enum class Field : uint8_t { MuS, MuD, Stiffness, KE, KC, FPStar, FEStar, KTheta, ForceScale, Preset };
  Field field = Field::MuS;
  int16_t lesion = -1;  ///< the lesion whose materials change; -1 for ForceScale
  double value = 0.0;   ///< in the field's unit (N/mm, N, N·mm/rad, 1); Preset: 0 mild, 1 severe
};

/// Applies a change to the model's materials (what the servo thread does between steps). Returns
/// false when it does not apply (unknown lesion, non-finite or out-of-range value).
bool apply_param_change(Model& model, const ParamChange& change);

/// One recorded sample (servo -> recorder), at the servo rate.
struct ServoSample {
  double t = 0.0;                 ///< s since the loop started
  Pose haptic;
  Pose graphic;
  Vec3 force = Vec3::Zero();      ///< N, rendered (after safety)
  Vec3 torque = Vec3::Zero();     ///< N·mm, rendered
  float depth = 0.0f;             ///< mm
  float step_us = 0.0f;           ///< µs
  float soft_tissue_force = 0.0f; ///< N
  uint32_t step_flags = 0;        ///< StepFlag bits
  uint32_t safety_flags = 0;      ///< SafetyFlag bits
  uint16_t contacts = 0;
  int8_t lesion = -1;
  InteractionState state = InteractionState::Free;
  bool overrun = false;           ///< this cycle missed its deadline
  uint32_t buttons = 0;
};

/// Step time and loop jitter, as a fixed-bin histogram (allocation-free to fill).
class TimingHistogram {
 public:
  static constexpr int kBins = 4096;       ///< 0.25 µs bins up to 1024 µs, the last bin holds the rest
  static constexpr double kBinUs = 0.25;   ///< µs
  void add(double us);
  [[nodiscard]] double percentile(double p) const;  ///< µs (bin upper edge); 0 when empty
  [[nodiscard]] double max() const { return max_; } ///< µs
  [[nodiscard]] uint64_t count() const { return count_; }

 private:
  std::array<uint64_t, kBins> bins_{};
  uint64_t count_ = 0;
  double max_ = 0.0;
};

struct TimingReport {
  double step_p50 = 0, step_p99 = 0, step_p999 = 0, step_max = 0;        ///< µs
  double jitter_p50 = 0, jitter_p99 = 0, jitter_p999 = 0, jitter_max = 0;  ///< µs, wake-up lateness
  uint64_t cycles = 0;
  uint64_t overruns = 0;
  double rate_hz = 0.0;  ///< measured
};

/// What the servo thread publishes every cycle for the viewer.
struct ServoSnapshot {
  StepOutput out;
  DeviceState device;
  Vec3 force = Vec3::Zero();   ///< N, rendered
  Vec3 torque = Vec3::Zero();  ///< N·mm, rendered
  uint32_t safety_flags = 0;
  double t = 0.0;              ///< s since start
  uint64_t cycle = 0;
  uint64_t overruns = 0;
  double rate_hz = 0.0;        ///< measured over the last second
};

struct ServoOptions {
  double rate_hz = 1000.0;            ///< Hz, 1 kHz default, up to 10 kHz
  bool realtime = true;               ///< ask for SCHED_FIFO (reports when refused)
  SafetyParams safety;
  SpscQueue<ServoSample>* record = nullptr;  ///< where samples go (the recorder's queue), optional
};

class ServoLoop {
 public:
  /// The loop owns a State for `model`; `model` and `device` must outlive it. Only the servo thread
  /// touches `model` while running (parameter changes arrive through post()).
  ServoLoop(Model& model, Device& device, const ServoOptions& options);
  ~ServoLoop();
  ServoLoop(const ServoLoop&) = delete;
  ServoLoop& operator=(const ServoLoop&) = delete;

  void start();
  void stop();
  [[nodiscard]] bool running() const { return running_.load(); }
  /// "SCHED_FIFO priority N" or why real-time priority was refused.
  [[nodiscard]] std::string realtime_status() const;
  /// The latest snapshot, if a new one was published since the last call (one reader thread).
  bool latest(ServoSnapshot& out) { return snapshots_.read(out); }
  /// Queues a parameter change (one producer thread); false when the queue is full.
  bool post(const ParamChange& change) { return changes_.push(change); }
  /// Timing so far (exact after stop(); approximate while running).
  [[nodiscard]] TimingReport timing() const;
  /// Samples that did not fit in the record queue.
  [[nodiscard]] uint64_t dropped_samples() const { return dropped_.load(); }

 private:
  void run();
  Model& model_;
  Device& device_;
  ServoOptions options_;
  std::unique_ptr<State> state_;
  ForceSafety safety_;
  TripleBuffer<ServoSnapshot> snapshots_;
  SpscQueue<ParamChange> changes_{256};
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<uint64_t> dropped_{0};
  std::string realtime_status_;
  TimingHistogram step_hist_, jitter_hist_;
  uint64_t cycles_ = 0, overruns_ = 0;
  double elapsed_ = 0.0;
};

}  // namespace cariesim
