// Sampling a trajectory (common/trajectory.hpp): linear position, slerp rotation between samples.
#include "cariesim/common/trajectory.hpp"

#include <algorithm>

namespace cariesim {

namespace {

// Interpolates between two samples: linear position, slerp rotation.
Pose blend(const Pose& a, const Pose& b, double u) {
  Pose out;
  out.p = a.p + (b.p - a.p) * u;
  out.q = a.q.slerp(u, b.q).normalized();
  return out;
}

}  // namespace

Pose Trajectory::sample(double time) const {
  // Clamped at both ends; inside, a binary search for the segment.
  if (time <= t.front()) return pose.front();
  if (time >= t.back()) return pose.back();
  const auto i = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin()) - 1;
  return blend(pose[i], pose[i + 1], (time - t[i]) / (t[i + 1] - t[i]));
}

Pose TrajectoryCursor::at(double time) {
  const Trajectory& tr = *trajectory_;
  // Clamped at both ends.
  if (time <= tr.t.front()) {
    segment_ = 0;
    return tr.pose.front();
  }
  if (time >= tr.t.back()) return tr.pose.back();
  // Walk forward from the last segment; restart the walk when time went backwards.
  if (segment_ >= tr.t.size() - 1 || tr.t[segment_] > time) segment_ = 0;
  while (tr.t[segment_ + 1] < time) ++segment_;
  const double u = (time - tr.t[segment_]) / (tr.t[segment_ + 1] - tr.t[segment_]);
  return blend(tr.pose[segment_], tr.pose[segment_ + 1], u);
}

}  // namespace cariesim
