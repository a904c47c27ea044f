#pragma once
// Running the `cariesim` binary from the command-line tests.
#include <filesystem>
#include <string>

namespace cariesim::test {

struct CommandResult {
  int status = -1;  ///< exit status, -1 when the process did not exit normally
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs `cariesim ARGS` (CARIESIM_EXE) through the shell with `env` (e.g. "NAME='value'") in
/// front; its streams go through files in `scratch`.
CommandResult run_cariesim(const std::string& args, const std::filesystem::path& scratch,
                           const std::string& env = "");

}  // namespace cariesim::test
