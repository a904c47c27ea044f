#pragma once
// Running a call that may never return (a crafted input that made a reader spin) in a child process
// with a deadline, so a test can fail on it instead of hanging; the child is killed at the deadline.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <exception>
#include <functional>
#include <string>
#include <thread>

namespace cariesim::test {

/// What a call did in its child process.
struct DeadlineResult {
  bool finished = false;  ///< it returned or threw before the deadline
  bool threw = false;     ///< it threw (`message` holds what())
  std::string message;    ///< the exception's message, or "did not finish within N s"
  double seconds = 0.0;   ///< wall time until it finished or was killed
};

/// Runs `call` in a forked child and waits at most `seconds` for it. Use it only where the test's
/// process has no other thread running (the child inherits none of them).
inline DeadlineResult run_with_deadline(const std::function<void()>& call, double seconds) {
  int channel[2];
  DeadlineResult result;
  if (::pipe(channel) != 0) {
    result.message = "pipe failed";
    return result;
  }
  const auto start = std::chrono::steady_clock::now();
  const pid_t child = ::fork();
  if (child == 0) {
    // The child: run, report "R" (returned) or "T<message>" (threw), exit without cleanup.
    ::close(channel[0]);
    std::string report = "R";
    try {
      call();
    } catch (const std::exception& e) {
      report = std::string("T") + e.what();
    } catch (...) {
      report = "T(an exception that is not a std::exception)";
    }
    std::size_t done = 0;
    while (done < report.size()) {
      const ssize_t n = ::write(channel[1], report.data() + done, report.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(channel[1]);
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (done == child) {
      result.finished = true;
      break;
    }
    if (result.seconds > seconds) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      result.message = "did not finish within " + std::to_string(seconds) + " s";
      ::close(channel[0]);
      return result;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::string report;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(channel[0], buffer, sizeof buffer);
    if (n <= 0) break;
    report.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(channel[0]);
  if (!report.empty() && report[0] == 'T') {
    result.threw = true;
    result.message = report.substr(1);
  } else if (report.empty()) {
    result.message = "the child died (status " + std::to_string(status) + ")";
    result.finished = false;
  }
  return result;
}

}  // namespace cariesim::test
