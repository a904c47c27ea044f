#include "cariesim/io/process.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <string_view>

#include "cariesim/common/error.hpp"

extern char** environ;

namespace cariesim::io {

namespace {

using Clock = std::chrono::steady_clock;

// How often a wait without output looks whether the child has ended (a grandchild may hold the
// pipes open after the child exited).
constexpr int kPollMs = 100;

// A pipe whose ends close themselves; both ends close on exec in this process's other children.
struct Pipe {
  int read = -1, write = -1;
  Pipe() {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw Error(std::string("cannot make a pipe: ") + std::strerror(errno));
    read = fds[0];
    write = fds[1];
  }
  ~Pipe() {
    close_read();
    close_write();
  }
  Pipe(const Pipe&) = delete;
  Pipe& operator=(const Pipe&) = delete;
  void close_read() {
    if (read >= 0) ::close(read);
    read = -1;
  }
  void close_write() {
    if (write >= 0) ::close(write);
    write = -1;
  }
};

// The spawn's file actions and attributes, destroyed with it.
struct SpawnSetup {
  posix_spawn_file_actions_t actions{};
  posix_spawnattr_t attr{};
  SpawnSetup() {
    posix_spawn_file_actions_init(&actions);
    posix_spawnattr_init(&attr);
  }
  ~SpawnSetup() {
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
  }
  SpawnSetup(const SpawnSetup&) = delete;
  SpawnSetup& operator=(const SpawnSetup&) = delete;
};

// Appends `n` bytes to `text`, keeping at most the last `max` (and saying when some were dropped).
void keep_tail(std::string& text, bool& cut, const char* bytes, std::size_t n, std::size_t max) {
  text.append(bytes, n);
  if (text.size() > 2 * max + 4096) {
    text.erase(0, text.size() - max);
    cut = true;
  }
}

void trim_tail(std::string& text, bool& cut, std::size_t max) {
  if (text.size() > max) {
    text.erase(0, text.size() - max);
    cut = true;
  }
}

}  // namespace

std::string ProcessResult::describe() const {
  if (!started) return fmt::format("could not be started: {}", std::strerror(start_error));
  if (timed_out) return "was killed after its time limit";
  if (signal != 0) return fmt::format("was killed by signal {} ({})", signal, ::strsignal(signal));
  return fmt::format("exited with status {}", exit_code);
}

ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options) {
  if (argv.empty() || argv.front().empty()) throw Error("run_process: no program to run");
  ProcessResult result;
  Pipe err;
  std::optional<Pipe> out;
  if (options.stdout_to == ChildStdout::Capture) out.emplace();

  // The child's descriptors: stdin from /dev/null or the file given, stdout as asked, stderr into the pipe, nothing else.
  SpawnSetup setup;
  posix_spawn_file_actions_addopen(&setup.actions, 0,
                                   options.stdin_file.empty() ? "/dev/null" : options.stdin_file.c_str(),
                                   O_RDONLY, 0);
  switch (options.stdout_to) {
    case ChildStdout::Discard:
      posix_spawn_file_actions_addopen(&setup.actions, 1, "/dev/null", O_WRONLY, 0);
      break;
    case ChildStdout::ToStderr:
      posix_spawn_file_actions_adddup2(&setup.actions, 2, 1);
      break;
    case ChildStdout::Capture:
      posix_spawn_file_actions_adddup2(&setup.actions, out->write, 1);
      break;
  }
  posix_spawn_file_actions_adddup2(&setup.actions, err.write, 2);
  posix_spawn_file_actions_addclosefrom_np(&setup.actions, 3);
  if (!options.working_dir.empty())
    posix_spawn_file_actions_addchdir_np(&setup.actions, options.working_dir.c_str());
  // Default signal handling and an empty mask, whatever this process's threads changed.
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  sigdelset(&all, SIGKILL);
  sigdelset(&all, SIGSTOP);
  posix_spawnattr_setsigmask(&setup.attr, &none);
  posix_spawnattr_setsigdefault(&setup.attr, &all);
  posix_spawnattr_setflags(&setup.attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);

  // The argument vector as the C strings posix_spawn takes; a name without '/' is looked up in PATH.
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The environment: this process's, with the options' entries replacing those of the same name.
  std::vector<char*> env;
  const auto name_of = [](std::string_view entry) { return entry.substr(0, entry.find('=')); };
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string_view name = name_of(*e);
    if (std::none_of(options.environment.begin(), options.environment.end(),
                     [&](const std::string& add) { return name_of(add) == name; }))
      env.push_back(*e);
  }
  for (const std::string& add : options.environment) env.push_back(const_cast<char*>(add.c_str()));
  env.push_back(nullptr);
  pid_t pid = -1;
  const bool search = argv.front().find('/') == std::string::npos;
  const int rc = search ? ::posix_spawnp(&pid, args[0], &setup.actions, &setup.attr, args.data(), env.data())
                        : ::posix_spawn(&pid, args[0], &setup.actions, &setup.attr, args.data(), env.data());
  err.close_write();
  if (out) out->close_write();
  if (rc != 0) {
    result.start_error = rc;
    return result;
  }
  result.started = true;

  // Read both pipes until they close, the child ends or its time is up.
  const bool limited = options.timeout_s > 0.0 && std::isfinite(options.timeout_s);
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(limited ? options.timeout_s : 0.0));
  int status = 0;
  bool reaped = false;
  char buffer[4096];
  for (;;) {
    pollfd fds[2];
    nfds_t count = 0;
    if (err.read >= 0) fds[count++] = {err.read, POLLIN, 0};
    if (out && out->read >= 0) fds[count++] = {out->read, POLLIN, 0};
    if (count == 0 || reaped) break;
    int wait_ms = kPollMs;
    if (limited) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) {
        ::kill(pid, SIGKILL);
        result.timed_out = true;
        break;
      }
      wait_ms = static_cast<int>(std::min<long long>(left, kPollMs));
    }
    const int ready = ::poll(fds, count, wait_ms);
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) {
      // Nothing to read: has the child ended (and left its pipes to a grandchild)?
      if (::waitpid(pid, &status, WNOHANG) == pid) reaped = true;
      continue;
    }
    for (nfds_t i = 0; i < count; ++i) {
      if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
      const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      const bool is_err = fds[i].fd == err.read;
      if (n <= 0) {
        is_err ? err.close_read() : out->close_read();
        continue;
      }
      const auto bytes = static_cast<std::size_t>(n);
      if (is_err) {
        keep_tail(result.err, result.err_cut, buffer, bytes, options.max_output_bytes);
        if (options.echo_stderr) (void)!::write(2, buffer, bytes);
      } else {
        keep_tail(result.out, result.out_cut, buffer, bytes, options.max_output_bytes);
      }
    }
  }
  trim_tail(result.err, result.err_cut, options.max_output_bytes);
  trim_tail(result.out, result.out_cut, options.max_output_bytes);

  // Its end: exit status or signal, waiting out the rest of its time once the pipes closed.
  while (!reaped) {
    const pid_t done = ::waitpid(pid, &status, limited && !result.timed_out ? WNOHANG : 0);
    if (done == pid) {
      reaped = true;
    } else if (done < 0 && errno != EINTR) {
      break;
    } else if (done == 0) {
      if (Clock::now() >= deadline) {
        ::kill(pid, SIGKILL);
        result.timed_out = true;
      } else {
        ::usleep(10000);
      }
    }
  }
  if (reaped && WIFEXITED(status) && !result.timed_out) result.exit_code = WEXITSTATUS(status);
  if (reaped && WIFSIGNALED(status)) result.signal = WTERMSIG(status);
  return result;
}

}  // namespace cariesim::io
