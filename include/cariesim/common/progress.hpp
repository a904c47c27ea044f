#pragma once
/// Progress reporting for long offline work (tree building, experiments). `--quiet` passes nullptr.

#include <functional>
#include <string_view>

namespace cariesim {

/// Called with a stage name and a fraction in [0, 1]; may be empty.
using ProgressFn = std::function<void(std::string_view stage, double fraction)>;

/// Calls `fn` when it is set.
inline void report(const ProgressFn& fn, std::string_view stage, double fraction) {
  if (fn) fn(stage, fraction);
}

}  // namespace cariesim
