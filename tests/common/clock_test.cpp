// wait_until_ns (common/clock.hpp): it never returns before its deadline, whether it sleeps the whole
// wait or polls its last stretch, and it sleeps all but that stretch (the servo thread's share of a
// core). Only CPU time is bounded, and loosely; no wall-clock speed is asserted.
#include "cariesim/common/clock.hpp"

#include <gtest/gtest.h>

#include <ctime>

namespace cariesim {
namespace {

// ns of CPU time this thread has used.
int64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

TEST(WaitUntil, NeverReturnsBeforeItsDeadline) {
  for (const int64_t spin_ns : {int64_t{0}, int64_t{100000}, int64_t{2000000}}) {
    for (const int64_t ahead_ns :
         {int64_t{-1000000}, int64_t{0}, int64_t{50000}, int64_t{300000}, int64_t{3000000}}) {
      for (int repeat = 0; repeat < 5; ++repeat) {
        const int64_t deadline = monotonic_ns() + ahead_ns;
        wait_until_ns(deadline, spin_ns);
        EXPECT_GE(monotonic_ns(), deadline)
            << "spin " << spin_ns << " ns, deadline " << ahead_ns << " ns ahead";
      }
    }
  }
}

TEST(WaitUntil, SleepsAllButTheLastStretch) {
  // A 40 ms wait that polls its last 0.2 ms uses far less than 40 ms of CPU time; one that polled
  // the whole wait would use nearly all of it (unless preempted, which only lowers it).
  const int64_t cpu_before = thread_cpu_ns();
  wait_until_ns(monotonic_ns() + 40000000, 200000);
  EXPECT_LT(thread_cpu_ns() - cpu_before, 20000000);
}

}  // namespace
}  // namespace cariesim
