#pragma once
// Hostile inputs that are no regular files, shared by the tests: a FIFO (named pipe) with no writer,
// which blocks a plain open() forever, and a check that a reader refuses it instead of blocking.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <exception>
#include <filesystem>
#include <future>
#include <string>

namespace cariesim::test {

/// Makes a FIFO at `path` (replacing nothing); false when the file system cannot hold one.
inline bool make_fifo(const std::filesystem::path& path) { return ::mkfifo(path.c_str(), 0600) == 0; }

/// What a reader did with a FIFO.
struct FifoOutcome {
  bool blocked = false;  ///< it was still waiting after the time allowed (then it was released)
  std::string error;     ///< the message it threw ("" when it returned)
};

/// Runs `read` (which reads `fifo`) on another thread. When it has not finished within `seconds`, it
/// blocked: a writer then opens and closes the FIFO, so the reader sees an end of file and the test
/// can go on (and fail) instead of hanging.
template <typename F>
FifoOutcome read_fifo(const std::filesystem::path& fifo, F read, double seconds = 5.0) {
  std::future<std::string> done = std::async(std::launch::async, [read]() -> std::string {
    try {
      read();
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  });
  FifoOutcome outcome;
  const auto limit = std::chrono::duration<double>(seconds);
  if (done.wait_for(limit) != std::future_status::ready) {
    outcome.blocked = true;
    while (done.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
      const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
      if (fd >= 0) ::close(fd);
    }
  }
  outcome.error = done.get();
  return outcome;
}

}  // namespace cariesim::test
