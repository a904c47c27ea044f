#include "force_history.hpp"

#include <algorithm>

namespace cariesim::viewer {

ForceHistory::ForceHistory(double window, std::size_t capacity)
    : window_(window > 0.0 ? window : 5.0), ring_(std::max<std::size_t>(capacity, 2)) {}

void ForceHistory::clear() {
  head_ = 0;
  size_ = 0;
}

void ForceHistory::add(double t, const Vec3& force, const Vec3& torque) {
  // A restarted servo clock starts a new history; repeated snapshots add nothing.
  if (size_ > 0) {
    const double newest = at(size_ - 1).t;
    if (t < newest)
      clear();
    else if (t == newest)
      return;
  }
  const Sample s{
      t,
      {static_cast<float>(force.norm()), static_cast<float>(force.x()), static_cast<float>(force.y()),
       static_cast<float>(force.z()), static_cast<float>(torque.norm())}};
  // Append, overwriting the oldest when full.
  if (size_ < ring_.size()) {
    ring_[(head_ + size_) % ring_.size()] = s;
    ++size_;
  } else {
    ring_[head_] = s;
    head_ = (head_ + 1) % ring_.size();
  }
}

void ForceHistory::resample(Series series, int points, std::vector<float>& out) const {
  out.assign(static_cast<std::size_t>(std::max(points, 0)), 0.0f);
  if (size_ == 0 || points <= 0) return;
  const int k = static_cast<int>(series);
  const double t_end = at(size_ - 1).t;
  const double t_start = t_end - window_;
  // Walk the grid and the samples together: the latest sample at or before each grid time.
  std::size_t j = 0;
  bool have = false;
  for (int i = 0; i < points; ++i) {
    const double t = points == 1 ? t_end : t_start + window_ * i / (points - 1);
    while (j < size_ && at(j).t <= t) {
      have = true;
      ++j;
    }
    out[static_cast<std::size_t>(i)] = have ? at(j - 1).f[k] : 0.0f;
  }
}

float ForceHistory::max_in_window(Series series) const {
  if (size_ == 0) return 0.0f;
  const int k = static_cast<int>(series);
  const double t_start = at(size_ - 1).t - window_;
  float best = 0.0f;
  for (std::size_t i = 0; i < size_; ++i)
    if (at(i).t >= t_start) best = std::max(best, at(i).f[k]);
  return best;
}

}  // namespace cariesim::viewer
