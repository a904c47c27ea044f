// Which CPUs a thread runs on, and at what real-time priority (Linux): the servo loop's two threads,
// the UDP bridge's threads, and the tests and benchmarks that take a CPU away from them.
// Not for the servo cycle (allowed_cpus allocates).
#pragma once

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <vector>

namespace cariesim {

/// The CPUs this process may run on (its affinity), highest first; empty when it cannot be read.
inline std::vector<int> allowed_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<int> cpus;
  if (sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (int cpu = CPU_SETSIZE - 1; cpu >= 0; --cpu)
    if (CPU_ISSET(cpu, &set)) cpus.push_back(cpu);
  return cpus;
}

/// Pins `thread` to the CPUs in `cpus` (one or more); false when refused.
inline bool pin_thread(pthread_t thread, const std::vector<int>& cpus) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (const int cpu : cpus) CPU_SET(cpu, &set);
  return pthread_setaffinity_np(thread, sizeof set, &set) == 0;
}

/// `priority` within SCHED_FIFO's range.
inline int clamp_fifo_priority(int priority) {
  return std::clamp(priority, sched_get_priority_min(SCHED_FIFO), sched_get_priority_max(SCHED_FIFO));
}

/// Puts `thread` under SCHED_FIFO at clamp_fifo_priority(priority); 0, or the error number
/// pthread_setschedparam gave.
inline int set_fifo_priority(pthread_t thread, int priority) {
  sched_param sp{};
  sp.sched_priority = clamp_fifo_priority(priority);
  return pthread_setschedparam(thread, SCHED_FIFO, &sp);
}

}  // namespace cariesim
