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

/// Waits until the absolute CLOCK_MONOTONIC time `deadline_ns` (ns): sleeps until `spin_ns` (ns)
/// before it, then polls the clock. A thread that sleeps to its deadline wakes when the kernel (on a
/// virtual machine, the hypervisor) gets round to it, tens to hundreds of µs late; one that polls
/// for the last stretch starts on time whenever the sleep ended within that stretch. Never returns
/// before the deadline. spin_ns <= 0 sleeps the whole wait.
inline void wait_until_ns(int64_t deadline_ns, int64_t spin_ns) {
  if (spin_ns <= 0) {
    sleep_until_ns(deadline_ns);
    return;
  }
  if (monotonic_ns() < deadline_ns - spin_ns) sleep_until_ns(deadline_ns - spin_ns);
  while (monotonic_ns() < deadline_ns) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();  // lets a sibling hyper-thread run while this one polls
#endif
  }
}

/// The current wall-clock time as ISO 8601 UTC with milliseconds ("2024-05-01T12:00:00.123Z"): when
/// a recorded session started and ended. Not for the servo thread (it allocates).
std::string utc_now_iso8601();

}  // namespace cariesim
