#pragma once
/// Starting a child process (the figure scripts' python3): the one place cariesim does. The child
/// gets an argument vector through posix_spawn, never a shell, so no character of a path or name is
/// ever interpreted; its stdin is /dev/null (or a file given), every descriptor of this process but the three standard
/// ones is closed in it, and its signal mask and dispositions are the defaults. Its stderr is captured
/// (the last `max_stderr_bytes`), its exit status or signal reported, and an optional timeout kills it.
#include <cstddef>
#include <string>
#include <vector>

namespace cariesim::io {

/// Where the child's stdout goes.
enum class ChildStdout {
  Discard,   ///< /dev/null
  ToStderr,  ///< this process's stderr (progress text beside our own messages, never on our stdout)
  Capture,   ///< into ProcessResult::out (bounded like stderr)
};

struct ProcessOptions {
  ChildStdout stdout_to = ChildStdout::Discard;
  /// Also copy the child's stderr to this process's stderr as it arrives (it is captured either way).
  bool echo_stderr = false;
  /// Seconds after which the child is killed (SIGKILL); 0 waits without a limit.
  double timeout_s = 0.0;
  /// Bytes of stderr (and of captured stdout) kept: the last ones, where a traceback's error is.
  std::size_t max_output_bytes = std::size_t{64} << 10;
  /// A file the child reads as its stdin; empty: /dev/null.
  std::string stdin_file;
  /// The child's working folder; empty: this process's.
  std::string working_dir;
  /// "NAME=value" entries added to (or replacing the same names in) this process's environment.
  std::vector<std::string> environment;
};

struct ProcessResult {
  /// False when the program could not be started (see start_error); nothing ran.
  bool started = false;
  /// errno of the failed start (ENOENT: no such program), 0 when it started.
  int start_error = 0;
  /// The exit status when the child exited, -1 otherwise.
  int exit_code = -1;
  /// The signal that ended the child, 0 when it exited.
  int signal = 0;
  /// True when the timeout killed it.
  bool timed_out = false;
  /// The last max_output_bytes of its stderr (and stdout when captured); `*_cut` when more came.
  std::string err, out;
  bool err_cut = false, out_cut = false;

  /// True when it ran and exited with status 0.
  [[nodiscard]] bool ok() const { return started && exit_code == 0; }
  /// "exited with status 2", "killed by signal 9 (Killed)", "killed after the 300 s time limit",
  /// "could not be started: No such file or directory".
  [[nodiscard]] std::string describe() const;
};

/// Runs `argv` (argv[0] is the program: a path, or a name looked up in PATH) and waits for it.
/// Throws cariesim::Error only when the pipes cannot be made; a program that cannot start is a result.
ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options = {});

}  // namespace cariesim::io
