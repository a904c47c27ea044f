#include "cariesim/record/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

// Linear position, slerp rotation (the trajectory convention, scene/trajectory.hpp).
Pose blend(const Pose& a, const Pose& b, double f) {
  Pose out;
  out.p = a.p + f * (b.p - a.p);
  out.q = a.q.slerp(f, b.q);
  return out;
}

// Beyond this many steps forward a binary search is cheaper than walking.
constexpr std::size_t kMaxWalk = 16;

}  // namespace

ReplayDevice::ReplayDevice(const std::filesystem::path& file, bool loop)
    : ReplayDevice(load_recording(file), loop, file.string()) {}

// Keep the samples whose time is finite and increasing (a recording's are; anything else could not be
// played in order), then fix the loop period: the recording plus one sample interval.
ReplayDevice::ReplayDevice(Recording recording, bool loop, std::string description)
    : description_(std::move(description)),
      loop_(loop),
      info_(std::move(recording.info)),
      events_(std::move(recording.events)) {
  t_.reserve(recording.samples.size());
  samples_.reserve(recording.samples.size());
  for (const ServoSample& s : recording.samples) {
    if (!std::isfinite(s.t) || (!t_.empty() && !(s.t > t_.back()))) continue;
    t_.push_back(s.t);
    samples_.push_back(s);
  }
  if (t_.empty()) throw Error(description_ + ": the recording holds no samples to replay");
  double interval = 1.0 / 1000.0;
  if (t_.size() >= 2) {
    interval = duration() / static_cast<double>(t_.size() - 1);
  } else if (std::isfinite(info_.rate_hz) && info_.rate_hz > 0.0) {
    interval = 1.0 / info_.rate_hz;
  }
  period_ = duration() + interval;
}

DeviceInfo ReplayDevice::info() const {
  DeviceInfo out;
  out.name = "replay";
  out.description = fmt::format("{} ({} samples, {:.3f} s{})", description_, t_.size(), duration(),
                                loop_ ? ", looping" : "");
  out.renders_force = false;
  return out;
}

double ReplayDevice::recording_time(double now) const {
  const double elapsed = std::isfinite(now) ? std::max(now, 0.0) : 0.0;
  if (!loop_) return t_.front() + elapsed;
  return t_.front() + std::fmod(elapsed, period_);
}

bool ReplayDevice::finished(double now) const { return !loop_ && recording_time(now) > t_.back(); }

// Walk forward from the hint while time increases (constant time per servo cycle), else bisect.
std::size_t ReplayDevice::segment(double time, std::size_t hint) const {
  const std::size_t last = t_.size() - 1;
  if (!(time > t_.front())) return 0;
  if (time >= t_[last]) return last;
  if (hint < last && t_[hint] <= time) {
    for (std::size_t steps = 0; steps < kMaxWalk && hint < last; ++steps) {
      if (time < t_[hint + 1]) return hint;
      ++hint;
    }
  }
  return static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), time) - t_.begin()) - 1;
}

double ReplayDevice::blend_factor(std::size_t i, double time) const {
  if (i + 1 >= t_.size()) return 0.0;
  return std::clamp((time - t_[i]) / (t_[i + 1] - t_[i]), 0.0, 1.0);
}

// The haptic pose between the two samples around the played time, the segment's velocities, the
// buttons of the sample at or before it.
DeviceState ReplayDevice::read(double now) {
  const double time = recording_time(now);
  cursor_ = segment(time, cursor_);
  const std::size_t i = cursor_;
  const ServoSample& a = samples_[i];
  DeviceState state;
  state.buttons = a.buttons;
  state.stamp = now;
  state.sequence = ++sequence_;
  state.valid = !finished(now);
  if (i + 1 < t_.size()) {
    const ServoSample& b = samples_[i + 1];
    const double dt = t_[i + 1] - t_[i];
    state.pose = blend(a.haptic, b.haptic, blend_factor(i, time));
    state.velocity = (b.haptic.p - a.haptic.p) / dt;
    state.angular_velocity = rotation_vector(b.haptic.q * a.haptic.q.conjugate()) / dt;
  } else {
    state.pose = a.haptic;
  }
  return state;
}

void ReplayDevice::write(const Vec3& /*force*/, const Vec3& /*torque*/) {}

ServoSample ReplayDevice::recorded(double now) const {
  const double time = recording_time(now);
  const std::size_t i = segment(time, 0);
  ServoSample out = samples_[i];
  if (i + 1 < t_.size()) {
    const double f = blend_factor(i, time);
    out.haptic = blend(samples_[i].haptic, samples_[i + 1].haptic, f);
    out.graphic = blend(samples_[i].graphic, samples_[i + 1].graphic, f);
    out.t = std::min(time, t_.back());
  }
  return out;
}

Pose ReplayDevice::recorded_graphic(double now) const { return recorded(now).graphic; }

std::unique_ptr<Device> make_replay_device(const std::filesystem::path& file, bool loop) {
  return std::make_unique<ReplayDevice>(file, loop);
}

}  // namespace cariesim
