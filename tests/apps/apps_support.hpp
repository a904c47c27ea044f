#pragma once
// Running the `cariesim` binary from the command-line tests.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace cariesim::test {

struct CommandResult {
  int status = -1;  ///< exit status, -1 when the process did not exit normally
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs `cariesim ARGS` (CARIESIM_EXE), ARGS split into words as a shell would (support/command.hpp)
/// but started without one; `env` holds "NAME=value" words (quoted like ARGS) added to the
/// environment; `working_dir` is its folder (empty: the test's).
CommandResult run_cariesim(const std::string& args, const std::string& env = "",
                           const std::filesystem::path& working_dir = {});

/// A closed cube of side `s` mm as ASCII STL (12 outward triangles).
std::string cube_stl(double s);

/// A fixture with a scratch folder per test (`dir_`, under the temporary directory, named from
/// `prefix`, the test's name and the process id), made empty before the test and removed after it.
class ScratchTest : public ::testing::Test {
 protected:
  explicit ScratchTest(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           (prefix_ + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;

 private:
  std::string prefix_;
};

}  // namespace cariesim::test
