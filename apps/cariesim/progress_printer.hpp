#pragma once
// Progress of long work on stderr: one line per stage, updated in place.
#include <cstdio>
#include <memory>
#include <string>

#include "cariesim/common/progress.hpp"

namespace cariesim::cli {

/// A ProgressFn that redraws "stage  NN%" on stderr at most once per percent.
inline ProgressFn progress_printer() {
  auto last = std::make_shared<std::pair<std::string, int>>("", -1);
  return [last](std::string_view stage, double fraction) {
    const int percent = static_cast<int>(fraction * 100.0);
    if (last->first == stage && last->second == percent) return;
    const bool new_stage = last->first != stage;
    if (new_stage && !last->first.empty()) std::fputc('\n', stderr);
    last->first = std::string(stage);
    last->second = percent;
    std::fprintf(stderr, "\r%-40.*s %3d%%", static_cast<int>(stage.size()), stage.data(), percent);
    if (percent >= 100) {
      std::fputc('\n', stderr);
      last->first.clear();
    }
    std::fflush(stderr);
  };
}

}  // namespace cariesim::cli
