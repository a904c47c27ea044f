#pragma once
/// The monotonic clock the servo loop, the device bridge and its clients share (CLOCK_MONOTONIC),
/// and the one wall-clock time stamp of records (UTC, ISO 8601).
#include <time.h>

#include <cerrno>
#include <cstdint>
#include <string>

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

/// The current wall-clock time as ISO 8601 UTC with milliseconds ("2024-05-01T12:00:00.123Z"): when
/// a recorded session started and ended. Not for the servo thread (it allocates).
std::string utc_now_iso8601();

}  // namespace cariesim
