// Playing a trajectory (common/trajectory.hpp): the blend, the segment velocities, the loop rule.
#include "cariesim/common/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace cariesim {

// Linear position, slerp rotation, normalised.
Pose blend(const Pose& a, const Pose& b, double u) {
  Pose out;
  out.p = a.p + (b.p - a.p) * u;
  out.q = a.q.slerp(u, b.q).normalized();
  return out;
}

// Finite differences over the segment: mm/s and the rotation vector per second.
SegmentVelocity segment_velocity(const Pose& a, const Pose& b, double dt) {
  SegmentVelocity v;
  v.linear = (b.p - a.p) / dt;
  v.angular = rotation_vector(b.q * a.q.conjugate()) / dt;
  return v;
}

// The start for a time before it (or none), a period of `duration` when looping.
double playback_offset(double elapsed, double duration, bool loop) {
  const double e = std::isfinite(elapsed) ? std::max(elapsed, 0.0) : 0.0;
  if (!loop) return e;
  return duration > 0.0 ? std::fmod(e, duration) : 0.0;
}

Pose Trajectory::sample(double time) const {
  // Clamped at both ends; inside, a binary search for the segment.
  if (time <= t.front()) return pose.front();
  if (time >= t.back()) return pose.back();
  const auto i = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin()) - 1;
  return blend(pose[i], pose[i + 1], (time - t[i]) / (t[i + 1] - t[i]));
}

}  // namespace cariesim
