#pragma once
// The random draws of a trial (docs/training.md, "seeds"): one std::mt19937_64 per trial, seeded with
// the trial's seed, read through these three operations only, so the same seed gives the same trial
// with any standard library (the std distributions are implementation-defined; these are not).

#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace cariesim::training {

class Draws {
 public:
  explicit Draws(uint64_t seed) : engine_(seed) {}

  /// An index in [0, n): one engine output modulo n (n >= 1; the bias, below n / 2^64, is negligible).
  std::size_t index(std::size_t n) { return static_cast<std::size_t>(engine_() % n); }
  /// A number in [lo, hi]: lo + u (hi - lo), u = the output's top 53 bits / 2^53.
  double uniform(double lo, double hi) {
    const double u = static_cast<double>(engine_() >> 11) * 0x1.0p-53;
    return lo + u * (hi - lo);
  }
  /// Fisher-Yates: for k = n-1 down to 1, swap item k with item index(k + 1).
  template <typename T>
  void shuffle(std::vector<T>& items) {
    for (std::size_t k = items.size(); k > 1; --k) std::swap(items[k - 1], items[index(k)]);
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace cariesim::training
