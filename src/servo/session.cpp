// A session: device, servo loop and recorder built, started and stopped together (servo/session.hpp).
#include "cariesim/servo/session.hpp"

#include <fmt/format.h>

#include <utility>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/io/json.hpp"
#include "cariesim/record/replay.hpp"

namespace cariesim {

namespace {

// The device a spec names (the record module's replay backend registered beside the built-in ones),
// placed at the model's home and reporting the model's limits.
std::unique_ptr<Device> device_from_spec(const Model& model, const SessionOptions& options) {
  register_replay_device();
  DeviceOptions device;
  device.home = model.tool_home;
  device.limits = model.defaults.limits;
  device.input = model.settings.input;
  device.realtime = options.realtime;
  if (!options.device_profile.empty()) device.profile = options.device_profile;
  return make_device(options.device, device);
}

// The name of a parameter in "param" events of a record (docs/records.md).
const char* param_field_name(ParamChange::Field field) {
  using F = ParamChange::Field;
  switch (field) {
    case F::MuS:
      return "mu_s";
    case F::MuD:
      return "mu_d";
    case F::Stiffness:
      return "stiffness";
    case F::KE:
      return "k_e";
    case F::KC:
      return "k_c";
    case F::FPStar:
      return "f_p_star";
    case F::FEStar:
      return "f_e_star";
    case F::KTheta:
      return "k_theta";
    case F::ForceScale:
      return "force_scale";
    case F::Preset:
      return "preset";
  }
  return "?";
}

}  // namespace

std::string params_json(const Model& model, const Params& params) {
  // Every lesion's top material.
  io::JsonWriter json;
  json.begin_object().key("lesions").begin_array();
  for (const LesionModel& lesion : model.lesions) {
    const Material& m = params.materials.at(static_cast<std::size_t>(lesion.material));
    json.begin_object()
        .field("name", lesion.name)
        .field("mu_s", m.mu_s)
        .field("mu_d", m.mu_d)
        .field("k_e", m.k_e)
        .field("k_c", m.k_c.at(0.0))
        .field("stiffness", m.stiffness)
        .field("f_p_star", m.f_p_star)
        .field("f_e_star", m.f_e_star)
        .field("k_theta", m.k_theta)
        .end_object();
  }
  json.end_array();
  // The coupling gains and the device limits in force.
  json.key("gains").begin_object();
  json.field("k_trans", params.gains.k_trans).field("k_rot", params.gains.k_rot);
  json.end_object();
  json.key("limits").begin_object();
  json.field("max_force", params.limits.max_force)
      .field("max_stiffness", params.limits.max_stiffness)
      .field("max_torque", params.limits.max_torque);
  json.end_object();
  json.end_object();
  return json.str();
}

Session::Session(const Model& model, const SessionOptions& options)
    : Session(model, device_from_spec(model, options), options) {}

Session::Session(const Model& model, std::unique_ptr<Device> device, const SessionOptions& options)
    : model_(model), options_(options), device_(std::move(device)) {
  if (!device_) throw Error("session on " + options.scene + ": no device given for '" + options.device + "'");
  device_info_ = device_->info();
  const double rate = options.rate_hz > 0.0 ? options.rate_hz : model.servo_rate;
  check_servo_rate(rate);
  check_servo_spin(options.spin_us);

  // The session row, filled here for every kind of run: what ran, on what, and with which Params.
  const Params start = initial_params(model, device_info_.limits);
  info_.scene = options.scene;
  info_.scene_hash = model.scene_hash;
  info_.device = options.device;
  info_.rate_hz = rate;
  info_.parameters = params_json(model, start);
  info_.started_at = utc_now_iso8601();

  // A replayed recording made on another scene: its poses meet other geometry.
  if (const RecordingSource* replay = replayed_recording(*device_)) {
    const SessionInfo& recorded = replay->session();
    if (recorded.scene_hash != model.scene_hash)
      warning_ = "the replayed recording was made on scene '" + recorded.scene + "' (hash " +
                 fmt::format("{:016x}", recorded.scene_hash) + "), not on this one, '" + options.scene +
                 "' (hash " + fmt::format("{:016x}", model.scene_hash) + "): its poses meet other geometry";
  }

  // The recorder (it creates the file now), then the loop that feeds it.
  if (!options.record.empty())
    recorder_ = std::make_unique<Recorder>(options.record, info_, options.recorder);
  make_loop(start);
}

Session::~Session() { stop(); }

void Session::make_loop(const Params& params) {
  // A loop on the session's device, pushing samples into the record when there is one.
  ServoOptions servo;
  servo.rate_hz = info_.rate_hz;
  servo.realtime = options_.realtime;
  servo.spin_us = options_.spin_us;
  servo.standby = options_.standby;
  servo.safety = options_.safety;
  servo.record = recorder_ ? &recorder_->queue() : nullptr;
  servo.capture = options_.capture;
  servo.params = params;
  loop_ = std::make_unique<ServoLoop>(model_, *device_, servo);
  loop_->latest_params(params_);
  last_t_ = 0.0;
}

void Session::start() {
  if (started_) return;
  if (stopped_ && recorder_)
    throw Error(recorder_->file().string() + ": the record of this session was closed by stop()");
  // The writer first, so the first sample finds it draining; then the loop and its device.
  if (recorder_) recorder_->start();
  try {
    loop_->start();
  } catch (...) {
    if (recorder_) recorder_->stop();
    stopped_ = true;
    throw;
  }
  // A hardware device knows what it is once open (its model, serial, SDK, limits).
  device_info_ = device_->info();
  started_ = true;
}

void Session::stop() {
  // The loop (and its device) first, so the recorder drains every sample it will ever get.
  if (loop_) loop_->stop();
  if (recorder_) recorder_->stop();
  started_ = false;
  stopped_ = true;
}

bool Session::restart() {
  if (recorder_) return false;
  // The running Params as the old loop left them, into a new loop with a fresh engine state.
  const bool was_running = started_;
  loop_->stop();
  loop_->latest_params(params_);
  const Params keep = params_.params;
  loop_.reset();
  make_loop(keep);
  if (was_running) loop_->start();
  return true;
}

bool Session::running() const { return started_; }

bool Session::latest(ServoSnapshot& out) {
  if (!loop_->latest(out)) return false;
  last_t_ = out.t;
  return true;
}

bool Session::post(const ParamChange& change) {
  if (!loop_->post(change)) return false;
  // A recorded session notes the change at the servo time the owner last saw.
  if (recorder_) {
    RecordedEvent event;
    event.t = last_t_;
    event.kind = "param";
    event.detail = param_field_name(change.field);
    event.value = change.value;
    event.lesion = change.lesion;
    recorder_->record_event(event);
  }
  return true;
}

const Params& Session::params() {
  loop_->latest_params(params_);
  return params_.params;
}

}  // namespace cariesim
