// io/file.hpp: a path from elsewhere is read only when it names a regular file within its bound.
#include "cariesim/io/file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cariesim/common/error.hpp"
#include "support/fifo.hpp"

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

// LineReader: the lines of a regular file, the last one without '\n', CR kept as getline keeps it.
TEST_F(FileTest, LineReaderGivesEveryLineWithItsNumber) {
  const fs::path p = write("t.csv", "t,px\r\n\n0,1\nlast");
  LineReader in(p, "trajectory");
  std::string line;
  ASSERT_TRUE(in.next(line));
  EXPECT_EQ(line, "t,px\r");
  ASSERT_TRUE(in.next(line));
  EXPECT_EQ(line, "");
  ASSERT_TRUE(in.next(line));
  EXPECT_EQ(line, "0,1");
  ASSERT_TRUE(in.next(line));
  EXPECT_EQ(line, "last");
  EXPECT_EQ(in.line_number(), 4u);
  EXPECT_FALSE(in.next(line));
  // Lines longer than the buffer's 64 KiB come whole.
  const std::string long_line(200000, 'x');
  LineReader big(write("big.csv", "a\n" + long_line + "\nb\n"), "trajectory");
  ASSERT_TRUE(big.next(line));
  ASSERT_TRUE(big.next(line));
  EXPECT_EQ(line, long_line);
  ASSERT_TRUE(big.next(line));
  EXPECT_EQ(line, "b");
  EXPECT_FALSE(big.next(line));
}

// Issue 26 item 15: a FIFO, /dev/zero or a folder as a streamed input (a trajectory) is refused
// when it is opened, naming its kind, and nothing is read.
TEST_F(FileTest, LineReaderRefusesWhatIsNoRegularFile) {
  const fs::path fifo = dir_ / "pipe.csv";
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::FifoOutcome outcome = test::read_fifo(fifo, [fifo] { LineReader in(fifo, "trajectory"); });
  EXPECT_FALSE(outcome.blocked);
  EXPECT_NE(outcome.error.find("not a regular file (a FIFO (named pipe))"), std::string::npos)
      << outcome.error;
  EXPECT_NE(message([] { LineReader in("/dev/zero", "trajectory"); }).find("(a character device)"),
            std::string::npos);
  EXPECT_NE(message([&] { LineReader in(dir_, "trajectory"); }).find("(a folder)"), std::string::npos);
}

// The bounds: a file over its size, and a line over its length, named with the line's number.
TEST_F(FileTest, LineReaderBoundsTheFileAndEachLine) {
  const fs::path p = write("t.csv", "ab\n" + std::string(100, 'y') + "\n");
  std::string m = message([&] { LineReader in(p, "trajectory", 50); });
  EXPECT_NE(m.find("too large (104 bytes, at most 50)"), std::string::npos) << m;
  m = message([&] {
    LineReader in(p, "trajectory", kMaxTextBytes, 64);
    std::string line;
    while (in.next(line)) {
    }
  });
  EXPECT_NE(m.find(p.string() + ": trajectory: line 2 is longer than 64 bytes"), std::string::npos) << m;
  // A last line without '\n' is bounded too.
  m = message([&] {
    LineReader in(write("tail.csv", std::string(100, 'z')), "trajectory", kMaxTextBytes, 64);
    std::string line;
    while (in.next(line)) {
    }
  });
  EXPECT_NE(m.find("line 1 is longer than 64 bytes"), std::string::npos) << m;
}

}  // namespace
}  // namespace cariesim::io
