// io/process.hpp: children start from an argument vector (no shell), with their exit status or
// signal, their stderr (bounded), a timeout, and no descriptor of ours but the standard three.
#include "cariesim/io/process.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;

ProcessResult sh(const std::string& script, ProcessOptions options = {}) {
  return run_process({"/bin/sh", "-c", script}, options);
}

// An argument holding quotes, ';' and '$(...)' reaches the child as one argument,
// word for word; nothing of it runs.
TEST(RunProcess, ArgumentsAreNeverInterpreted) {
  const fs::path dir = fs::temp_directory_path() / ("cariesim-io-process-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string hostile =
      "r';touch " + (dir / "pwned").string() + ";'$(touch " + (dir / "pwned2").string() + ")";
  ProcessOptions options;
  options.stdout_to = ChildStdout::Capture;
  const ProcessResult r = run_process({"/usr/bin/printf", "%s", hostile}, options);
  ASSERT_TRUE(r.ok()) << r.describe() << r.err;
  EXPECT_EQ(r.out, hostile);
  EXPECT_FALSE(fs::exists(dir / "pwned"));
  EXPECT_FALSE(fs::exists(dir / "pwned2"));
  fs::remove_all(dir);
}

// The child runs in the folder it is given, with the entries it is given added to the environment
// (one of an existing name replaces it), the rest of this process's environment, and the stdin file
// it is given.
TEST(RunProcess, WorkingFolderAndEnvironmentAreTheChildsOnly) {
  const fs::path dir = fs::temp_directory_path() / ("cariesim-io-process-cwd-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  ::setenv("CARIESIM_PROCESS_TEST_KEPT", "kept", 1);
  ::setenv("CARIESIM_PROCESS_TEST_SWAPPED", "old", 1);
  ProcessOptions options;
  options.stdout_to = ChildStdout::Capture;
  options.working_dir = dir.string();
  options.environment = {"CARIESIM_PROCESS_TEST_SWAPPED=new", "CARIESIM_PROCESS_TEST_ADDED=a b;c"};
  std::ofstream(dir / "in.txt") << "from the file\n";
  options.stdin_file = (dir / "in.txt").string();
  const ProcessResult r = sh(
      "read line; echo \"$line\"; pwd; echo \"$CARIESIM_PROCESS_TEST_KEPT|$CARIESIM_PROCESS_TEST_SWAPPED|$CARIESIM_PROCESS_TEST_ADDED\"; "
      "env | grep -c '^CARIESIM_PROCESS_TEST_SWAPPED='",
      options);
  ASSERT_TRUE(r.ok()) << r.describe() << r.err;
  EXPECT_EQ(r.out, "from the file\n" + fs::canonical(dir).string() + "\nkept|new|a b;c\n1\n");
  EXPECT_STREQ(::getenv("CARIESIM_PROCESS_TEST_SWAPPED"), "old");
  fs::remove_all(dir);
}

TEST(RunProcess, ExitStatusSignalAndStderrAreReported) {
  const ProcessResult failed = sh("echo 'Traceback: it broke' >&2; exit 3");
  EXPECT_TRUE(failed.started);
  EXPECT_FALSE(failed.ok());
  EXPECT_EQ(failed.exit_code, 3);
  EXPECT_EQ(failed.err, "Traceback: it broke\n");
  EXPECT_EQ(failed.describe(), "exited with status 3");

  const ProcessResult killed = sh("kill -TERM $$");
  EXPECT_EQ(killed.exit_code, -1);
  EXPECT_EQ(killed.signal, SIGTERM);
  EXPECT_NE(killed.describe().find("killed by signal 15"), std::string::npos) << killed.describe();

  const ProcessResult missing = run_process({"cariesim-no-such-program-here"});
  EXPECT_FALSE(missing.started);
  EXPECT_EQ(missing.start_error, ENOENT);
  EXPECT_NE(missing.describe().find("could not be started"), std::string::npos);
}

TEST(RunProcess, StderrIsBoundedToItsEnd) {
  ProcessOptions options;
  options.max_output_bytes = 1000;
  const ProcessResult r =
      sh("i=0; while [ $i -lt 2000 ]; do echo line $i >&2; i=$((i+1)); done; echo LAST >&2", options);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.err.size(), 1000u);
  EXPECT_TRUE(r.err_cut);
  EXPECT_EQ(r.err.substr(r.err.size() - 5), "LAST\n");
}

TEST(RunProcess, ATimeoutKillsTheChild) {
  ProcessOptions options;
  options.timeout_s = 0.3;
  const auto start = std::chrono::steady_clock::now();
  const ProcessResult r = sh("sleep 30", options);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(r.timed_out);
  EXPECT_FALSE(r.ok());
  EXPECT_LT(took, 10.0);
  EXPECT_NE(r.describe().find("time limit"), std::string::npos);
  // A child that ends within its time is not touched.
  EXPECT_TRUE(sh("exit 0", options).ok());
}

// Close-on-exec hygiene: a descriptor this process opened without O_CLOEXEC is not the child's.
TEST(RunProcess, TheChildGetsOnlyTheStandardDescriptors) {
  // No O_CLOEXEC on purpose; a high number, apart from the one ls opens for /proc/self/fd.
  const int opened = ::open("/dev/null", O_RDONLY);
  const int leaked = ::fcntl(opened, F_DUPFD, 50);
  ::close(opened);
  ASSERT_GE(leaked, 50);
  ProcessOptions options;
  options.stdout_to = ChildStdout::Capture;
  const ProcessResult r = sh("ls /proc/self/fd", options);
  ::close(leaked);
  ASSERT_TRUE(r.ok()) << r.err;
  // ls itself opens one descriptor for /proc/self/fd: 0, 1, 2 and that one.
  EXPECT_EQ(r.out.find("\n" + std::to_string(leaked) + "\n"), std::string::npos) << r.out;
  int count = 0;
  for (const char c : r.out) count += c == '\n';
  EXPECT_LE(count, 4) << r.out;
}

}  // namespace
}  // namespace cariesim::io
