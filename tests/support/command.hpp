#pragma once
// Running a program from a test: an argument vector through io::run_process (posix_spawn), never a
// shell. A command written as one line (a documented example, a test's arguments with their paths in
// quotes) is split into words by Boost.Program_options' split_unix (blanks, quotes, backslashes), and
// nothing else of a shell applies: no redirection, variable, glob or `;`.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <boost/program_options/parsers.hpp>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cariesim/io/process.hpp"
#include "support/files.hpp"

namespace cariesim::test {

/// What a test's command printed and how it ended.
struct CommandOutput {
  int status = -1;  ///< exit status; -1 when it did not start or a signal or the timeout ended it
  std::string out, err;
  std::string how;  ///< io::ProcessResult::describe(): "exited with status 2", "killed by signal 9 ..."
};

/// The words of `line`: split at blanks, except inside quotes, a backslash escaping the next
/// character. Unlike a shell, split_unix ends a quoted part at either quote character, so quote a word
/// holding quotes with shell_word (single quotes, each ' written '\'').
inline std::vector<std::string> words(const std::string& line) {
  return boost::program_options::split_unix(line);
}

/// `text` as one word, whatever it holds: for words() and for a POSIX shell alike.
inline std::string shell_word(const std::string& text) {
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Runs `argv` and waits; stdout and stderr captured (their last 256 MiB). `options` may set the
/// working folder, environment entries and a timeout.
inline CommandOutput run_command(const std::vector<std::string>& argv, io::ProcessOptions options = {}) {
  options.stdout_to = io::ChildStdout::Capture;
  options.max_output_bytes = std::size_t{256} << 20;
  const io::ProcessResult r = io::run_process(argv, options);
  CommandOutput out;
  out.status = r.started && r.signal == 0 && !r.timed_out ? r.exit_code : -1;
  out.out = r.out;
  out.err = r.err;
  out.how = r.describe();
  return out;
}

/// Runs `program` with the words of `args` appended.
inline CommandOutput run_command(const std::string& program, const std::string& args,
                                 io::ProcessOptions options = {}) {
  std::vector<std::string> argv{program};
  for (std::string& w : words(args)) argv.push_back(std::move(w));
  return run_command(argv, std::move(options));
}

/// Rows of an SQL query on `db` through the sqlite3 shell (a reader independent of the project's own
/// database code), one line per row, '|' between columns; a shell that fails fails the test.
inline std::vector<std::string> sql_rows(const std::filesystem::path& db, const std::string& query) {
  const CommandOutput c = run_command({"sqlite3", db.string(), query});
  EXPECT_EQ(c.status, 0) << c.how << "\n" << c.out << c.err;
  std::vector<std::string> rows;
  std::istringstream lines(c.out);
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  return rows;
}

/// True when `name` is an executable file in a folder of PATH (what `command -v` finds).
inline bool on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string folders = path != nullptr ? path : "/usr/bin:/bin";
  for (std::size_t start = 0; start <= folders.size();) {
    const std::size_t end = std::min(folders.find(':', start), folders.size());
    const std::string file = folders.substr(start, end - start) + "/" + name;
    if (end > start && ::access(file.c_str(), X_OK) == 0) return true;
    start = end + 1;
  }
  return false;
}

/// True when /usr/bin/python3 can import `module` (e.g. "matplotlib").
inline bool python3_imports(const std::string& module) {
  return run_command({"/usr/bin/python3", "-c", "import " + module}).status == 0;
}

/// A running process whose program is `program` and one of whose arguments is `argument` (read from
/// /proc/PID/cmdline); 0 when there is none.
inline pid_t find_process(const std::string& program, const std::string& argument) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string cmdline = read_text(entry.path() / "cmdline");
    std::vector<std::string> argv;
    for (std::size_t start = 0; start < cmdline.size();) {
      const std::size_t end = std::min(cmdline.find('\0', start), cmdline.size());
      argv.push_back(cmdline.substr(start, end - start));
      start = end + 1;
    }
    if (!argv.empty() && argv.front() == program &&
        std::find(argv.begin() + 1, argv.end(), argument) != argv.end())
      return static_cast<pid_t>(std::stol(name));
  }
  return 0;
}

}  // namespace cariesim::test
