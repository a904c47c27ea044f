#pragma once
/// The monotonic clock the servo loop, the device bridge and its clients share (CLOCK_MONOTONIC).
#include <time.h>

#include <cerrno>
#include <cstdint>

namespace cariesim {

/// ns since an arbitrary fixed point (CLOCK_MONOTONIC).
inline int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

/// Sleeps until the absolute CLOCK_MONOTONIC time `deadline_ns` (ns), across signal interruptions.
inline void sleep_until_ns(int64_t deadline_ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline_ns / 1000000000);
  ts.tv_nsec = static_cast<long>(deadline_ns % 1000000000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace cariesim
