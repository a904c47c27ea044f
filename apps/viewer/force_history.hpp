#pragma once
/// The live force and torque plot's data (docs/design.md §5): a ring of the snapshots the viewer saw over
/// the last seconds, resampled on a uniform time grid for ImGui's PlotLines.

#include <cstddef>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim::viewer {

class ForceHistory {
 public:
  /// Which series to resample.
  enum class Series { ForceNorm, Fx, Fy, Fz, TorqueNorm };

  /// Keeps up to `capacity` samples and plots the last `window` seconds.
  explicit ForceHistory(double window = 5.0, std::size_t capacity = 4096);
  /// Adds a sample at servo time `t` (s): force (N) and torque (N·mm). A time before the newest one
  /// (a restarted loop) clears the history first; the same time again is ignored.
  void add(double t, const Vec3& force, const Vec3& torque);
  void clear();
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] double window() const { return window_; }  ///< s
  /// `points` values of a series over [newest - window, newest], the value at each grid time being
  /// that of the latest sample at or before it (0 before the first). Empty history: all zeros.
  void resample(Series series, int points, std::vector<float>& out) const;
  /// Largest value of a series within the window (0 when empty).
  [[nodiscard]] float max_in_window(Series series) const;

 private:
  struct Sample {
    double t;    // s
    float f[5];  // indexed by Series
  };
  [[nodiscard]] const Sample& at(std::size_t i) const { return ring_[(head_ + i) % ring_.size()]; }
  double window_;
  std::vector<Sample> ring_;
  std::size_t head_ = 0;  // oldest
  std::size_t size_ = 0;
};

}  // namespace cariesim::viewer
