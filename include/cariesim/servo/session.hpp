#pragma once
/// One run of the simulator on a model (docs/design.md §5): a device, the servo loop that drives the
/// engine with it, and an optional recorder, built, started and stopped in one place for both
/// `cariesim servo` and the viewer.
///
/// A Session makes the device from a spec (device/factory.hpp) or takes one already made (the
/// viewer's mouse); fills the record's SessionInfo once (scene, scene hash, device spec, rate, the
/// running Params as JSON, the start time from utc_now_iso8601); starts the recorder's writer before
/// the loop and stops the loop (and with it the device) before the recorder; posts parameter changes
/// and notes each in the record as a "param" event; and keeps the owner's copy of the running
/// Params from what the servo thread publishes (ServoLoop::latest_params).
///
///   SessionOptions options;
///   options.scene = "friction-block";
///   options.device = "udp:47000";
///   options.record = "session.db";
///   Session session(model, options);  // the device, the loop, the recorder
///   session.start();
///   ... session.latest(snapshot); session.post(change); session.params() ...
///   session.stop();
///
/// Threads: one owner thread (the viewer's UI thread, the command's main thread) calls every member;
/// the servo, device and recorder threads run inside.

#include <cstdint>
#include <memory>
#include <string>

#include "cariesim/device/device.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/servo/servo.hpp"

namespace cariesim {

/// What a Session runs and how.
struct SessionOptions {
  std::string scene;            ///< the scene name or file the model was built from (for the record)
  std::string device = "null";  ///< device spec (device/factory.hpp); for a ready-made device, its name
  std::string device_profile;   ///< a hardware device's profile file (device/profile.hpp); empty: the default
  double rate_hz = 0.0;         ///< Hz, the servo rate; 0: the model's (Model::servo_rate)
  bool realtime = true;         ///< ask for SCHED_FIFO (the servo thread, the UDP bridge's threads)
  double spin_us = kDefaultSpinUs;  ///< µs the servo thread polls before each deadline (ServoOptions)
  bool standby = true;              ///< a standby servo thread on a second CPU (ServoOptions::standby)
  /// The force safety layer's ramp and global scale (readings are judged by the model's InputLimits,
  /// Model::settings.input, which also bound the UDP bridge's transit delay)
  SafetyParams safety;
  std::string record;           ///< SQLite file to record the session into; empty: no record
  RecorderOptions recorder;     ///< how to record (overwrite, batch length, thresholds)
  /// Poses the servo thread takes at given servo times (ServoOptions::capture); it must outlive the
  /// session. Optional.
  TimedCapture* capture = nullptr;
};

class Session {
 public:
  /// Makes the device from options.device (make_device, with the model's home pose and limits),
  /// the servo loop and, when options.record is set, the recorder (which creates the file). Throws
  /// cariesim::Error naming what failed: the device spec, the rate, the record file.
  Session(const Model& model, const SessionOptions& options);
  /// The same with a device already made (e.g. the viewer's mouse); options.device names it in the
  /// record. `device` must not be null.
  Session(const Model& model, std::unique_ptr<Device> device, const SessionOptions& options);
  /// Stops everything (stop()).
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Starts the recorder's writer, then the servo loop (which starts the device). Throws what the
  /// device throws (e.g. a UDP port already bound); nothing runs then. No-op while running.
  void start();
  /// Stops the servo loop (and the device), then the recorder, which drains, commits and closes the
  /// record. Safe to call twice; the record cannot be resumed afterwards.
  void stop();
  /// A fresh engine state (the tool at the model's home) with the running Params kept: stops the
  /// loop, makes a new one, starts it again when it was running. Refused (false, nothing done) while
  /// recording, where the servo clock would start over.
  bool restart();
  /// True between start() and stop().
  [[nodiscard]] bool running() const;

  /// The latest snapshot, if a new one was published since the last call (ServoLoop::latest).
  bool latest(ServoSnapshot& out);
  /// Queues a parameter change for the servo thread and, when recording, notes it as a "param"
  /// event (docs/records.md) at the servo time of the latest snapshot seen. False when the queue is
  /// full (nothing noted). Whether the servo thread applied it shows in the published Params.
  bool post(const ParamChange& change);
  /// The running Params as the servo thread last published them (refreshed by this call).
  const Params& params();
  /// Their version (ServoSnapshot::params_version) as of the last params() call.
  [[nodiscard]] uint64_t params_version() const { return params_.version; }

  /// The model it runs on.
  [[nodiscard]] const Model& model() const { return model_; }
  /// The device (e.g. for its counters; dynamic_cast for a replay's recorded pose).
  [[nodiscard]] Device& device() { return *device_; }
  [[nodiscard]] const Device& device() const { return *device_; }
  /// What the device said it is when the session was made.
  /// What the device is: as made, then as started (a hardware device knows its model once open).
  /// The thread that starts and stops the session.
  [[nodiscard]] const DeviceInfo& device_info() const { return device_info_; }
  /// The servo loop (timing, realtime status, counters).
  [[nodiscard]] ServoLoop& loop() { return *loop_; }
  [[nodiscard]] const ServoLoop& loop() const { return *loop_; }
  /// The recorder, or nullptr without a record.
  [[nodiscard]] Recorder* recorder() { return recorder_.get(); }
  [[nodiscard]] const Recorder* recorder() const { return recorder_.get(); }
  /// The session row of the record (also filled without a record).
  [[nodiscard]] const SessionInfo& info() const { return info_; }
  /// Hz, the servo rate it runs at.
  [[nodiscard]] double rate_hz() const { return info_.rate_hz; }
  /// What the owner should tell the user about this session, empty when nothing: a replayed
  /// recording made on another scene (its scene hash differs from the model's), whose poses then
  /// meet other geometry.
  [[nodiscard]] const std::string& warning() const { return warning_; }

 private:
  void make_loop(const Params& params);

  const Model& model_;
  SessionOptions options_;
  std::unique_ptr<Device> device_;
  DeviceInfo device_info_;
  SessionInfo info_;
  std::string warning_;
  std::unique_ptr<Recorder> recorder_;
  std::unique_ptr<ServoLoop> loop_;  // declared last: destroyed first, before the device and recorder
  PublishedParams params_;           // the owner's copy of the running Params
  double last_t_ = 0.0;              // s, servo time of the latest snapshot seen
  bool started_ = false;
  bool stopped_ = false;
};

/// The running parameters as JSON, the record's `parameters` (docs/records.md): every lesion's top
/// material (mu_s, mu_d, k_e, k_c at depth 0, stiffness, f_p_star, f_e_star, k_theta), the coupling
/// gains and the device limits in force.
std::string params_json(const Model& model, const Params& params);

}  // namespace cariesim
