// Crash safety (issue 5 acceptance): "killing the process with SIGKILL while recording loses at most
// the last 100 ms of samples". A forked child records a synthetic stream through the real Recorder,
// fed by a thread that behaves like the servo loop (absolute deadlines at the servo rate, one
// non-blocking push per cycle) and publishes the index of the last sample it pushed in shared
// memory. The parent kills it with SIGKILL at a random moment after a second or so, reopens the
// database (SQLite recovers the WAL) and checks that the stored stream is continuous from the first
// sample to the last stored one and that the last stored one is within 100 ms of the last pushed.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <thread>

#include "cariesim/record/recorder.hpp"
#include "record/record_support.hpp"

namespace cariesim {
namespace {

using Clock = std::chrono::steady_clock;

// What the child shares with the parent (an anonymous shared mapping).
struct Shared {
  std::atomic<int64_t> pushed{-1};  // index of the last sample pushed
  std::atomic<int64_t> refused{0};  // pushes refused because the queue was full
  std::atomic<int> ready{0};        // 1 once the recorder and the servo thread run
  char error[256] = {};
};
static_assert(std::atomic<int64_t>::is_always_lock_free, "shared-memory counters must be lock-free");

// The child: record until killed (or give up after 30 s). Never returns into the test framework.
[[noreturn]] void record_until_killed(const std::filesystem::path& file, double rate, Shared* shared) {
  try {
    Recorder recorder(file, test::synthetic_session(rate));
    recorder.start();
    std::thread servo([&recorder, rate, shared] {
      const auto period =
          std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
      auto deadline = Clock::now();
      const auto last = static_cast<int64_t>(30.0 * rate);
      for (int64_t i = 0; i < last; ++i) {
        if (recorder.queue().push(test::synthetic_sample(static_cast<std::size_t>(i), rate))) {
          shared->pushed.store(i, std::memory_order_release);
        } else {
          shared->refused.fetch_add(1, std::memory_order_relaxed);
        }
        deadline += period;
        std::this_thread::sleep_until(deadline);
      }
    });
    shared->ready.store(1, std::memory_order_release);
    servo.join();
  } catch (const std::exception& e) {
    std::strncpy(shared->error, e.what(), sizeof shared->error - 1);
    _exit(3);
  }
  _exit(4);
}

struct RunResult {
  int64_t pushed = -1;   // last sample index pushed when killed
  int64_t stored = -1;   // last sample index in the database
  double lost_ms = 0.0;  // ms of sample time lost
};

// One run: fork, wait until recording, sleep `kill_after`, SIGKILL, then check the file.
RunResult kill_and_check(const std::filesystem::path& file, double rate, double kill_after) {
  RunResult result;
  void* memory = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  EXPECT_NE(memory, MAP_FAILED);
  if (memory == MAP_FAILED) return result;
  auto* shared = new (memory) Shared;
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid == 0) record_until_killed(file, rate, shared);
  EXPECT_GT(pid, 0) << "fork failed";
  if (pid < 0) return result;

  // Wait for the child to record (or to fail), then let it run and kill it.
  const auto give_up = Clock::now() + std::chrono::seconds(20);
  int status = 0;
  bool exited = false;
  while (shared->ready.load(std::memory_order_acquire) == 0 && Clock::now() < give_up) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!exited) {
    std::this_thread::sleep_for(std::chrono::duration<double>(kill_after));
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
      << "child ended otherwise: " << shared->error;
  EXPECT_EQ(shared->refused.load(), 0) << "the writer fell behind until the queue was full";
  result.pushed = shared->pushed.load(std::memory_order_acquire);
  munmap(memory, sizeof(Shared));

  // Reopen (WAL recovery) and check the stream: every sample from 0 to the last stored, in order and
  // exactly as pushed.
  const Recording recording = load_recording(file);
  EXPECT_TRUE(recording.info.ended_at.empty()) << "a killed recorder cannot have stamped the end";
  EXPECT_FALSE(recording.samples.empty());
  for (std::size_t i = 0; i < recording.samples.size(); ++i) {
    const ServoSample expected = test::synthetic_sample(i, rate);
    const ServoSample& got = recording.samples[i];
    if (got.t != expected.t || got.haptic.p != expected.haptic.p || got.force != expected.force) {
      ADD_FAILURE() << "stream not continuous at sample " << i << ": t " << got.t << " instead of "
                    << expected.t;
      break;
    }
  }
  result.stored = static_cast<int64_t>(recording.samples.size()) - 1;
  result.lost_ms = 1000.0 * static_cast<double>(result.pushed - result.stored) / rate;
  return result;
}

TEST(RecorderCrash, SigkillLosesAtMostTheLast100Milliseconds) {
  test::ScratchDir dir("crash");
  std::random_device entropy;
  const unsigned seed = entropy();
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> kill_after(1.0, 2.0);  // s
  std::printf("kill moments drawn with seed %u\n", seed);
  struct Plan {
    double rate;
    int runs;
  };
  int run = 0;
  for (const Plan plan : {Plan{1000.0, 6}, Plan{10000.0, 2}}) {
    for (int k = 0; k < plan.runs; ++k, ++run) {
      const auto file = dir / ("run" + std::to_string(run) + ".db");
      const double after = kill_after(random);
      const RunResult r = kill_and_check(file, plan.rate, after);
      std::printf(
          "run %d: %.0f Hz, killed %.3f s after start: pushed up to t = %.4f s, stored up to t = %.4f s, "
          "lost %.1f ms\n",
          run, plan.rate, after, r.pushed / plan.rate, r.stored / plan.rate, r.lost_ms);
      EXPECT_GE(r.stored, 0) << "run " << run;
      EXPECT_GE(r.pushed, r.stored) << "run " << run;
      EXPECT_LE(r.lost_ms, 100.0) << "run " << run << ": more than the last 100 ms lost";
      RecordProperty("run" + std::to_string(run) + "_lost_ms", std::to_string(r.lost_ms));
    }
  }
}

}  // namespace
}  // namespace cariesim
