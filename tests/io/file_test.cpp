// io/file.hpp: a path from elsewhere is read only when it names a regular file within its bound.
#include "cariesim/io/file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;

class FileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-io-file-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  // The message of the Error `f` throws ("" when it throws none).
  template <typename F>
  static std::string message(F f) {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(FileTest, ReadsARegularFileWhole) {
  const fs::path p = write("a.txt", std::string("line 1\nline 2\0x", 15));
  EXPECT_EQ(read_file(p, "scene"), std::string("line 1\nline 2\0x", 15));
  EXPECT_EQ(require_regular_file(p, "scene"), 15u);
  EXPECT_EQ(file_kind(p), FileKind::Regular);
}

TEST_F(FileTest, AFifoIsRefusedWithoutBlocking) {
  const fs::path p = dir_ / "pipe";
  ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
  EXPECT_EQ(file_kind(p), FileKind::Fifo);
  const std::string m = message([&] { read_file(p, "trajectory"); });
  EXPECT_NE(m.find(p.string() + ": trajectory: not a regular file (a FIFO (named pipe))"), std::string::npos) << m;
  EXPECT_NE(message([&] { require_regular_file(p, "answers"); }).find("FIFO"), std::string::npos);
}

TEST_F(FileTest, ADeviceAFolderAndNothingAreNamed) {
  EXPECT_NE(message([&] { read_file("/dev/zero", "mesh"); }).find("/dev/zero: mesh: not a regular file (a character device)"),
            std::string::npos);
  EXPECT_NE(message([&] { read_file(dir_, "study"); }).find("not a regular file (a folder)"), std::string::npos);
  EXPECT_NE(message([&] { read_file(dir_ / "none.yaml", "study"); }).find("none.yaml: study: file not found"),
            std::string::npos);
  EXPECT_NE(message([&] { require_regular_file(dir_ / "none.yaml", "study"); }).find("file not found"),
            std::string::npos);
}

TEST_F(FileTest, AFileOverItsBoundIsRefusedWithItsSize) {
  const fs::path p = write("big.csv", std::string(1000, 'x'));
  const std::string m = message([&] { read_file(p, "trajectory", 999); });
  EXPECT_NE(m.find("too large (1000 bytes, at most 999)"), std::string::npos) << m;
  EXPECT_EQ(read_file(p, "trajectory", 1000).size(), 1000u);
}

}  // namespace
}  // namespace cariesim::io
