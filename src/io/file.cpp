#include "cariesim/io/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

namespace {

FileKind kind_of(mode_t mode) {
  if (S_ISREG(mode)) return FileKind::Regular;
  if (S_ISDIR(mode)) return FileKind::Directory;
  if (S_ISFIFO(mode)) return FileKind::Fifo;
  if (S_ISCHR(mode)) return FileKind::CharDevice;
  if (S_ISBLK(mode)) return FileKind::BlockDevice;
  if (S_ISSOCK(mode)) return FileKind::Socket;
  return FileKind::Other;
}

[[noreturn]] void fail(const std::filesystem::path& path, std::string_view what, const std::string& why) {
  throw Error(path.string() + ": " + std::string(what) + ": " + why);
}

// The checks shared by require_regular_file and read_file, on a stat result.
void check_stat(const std::filesystem::path& path, std::string_view what, const struct stat& st,
                std::uintmax_t max_bytes) {
  const FileKind kind = kind_of(st.st_mode);
  if (kind != FileKind::Regular) fail(path, what, "not a regular file (" + std::string(describe(kind)) + ")");
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes)
    fail(path, what, "too large (" + std::to_string(size) + " bytes, at most " + std::to_string(max_bytes) + ")");
}

// Closes a descriptor when the read is done or fails.
struct Descriptor {
  int fd = -1;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

FileKind file_kind(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return FileKind::Missing;
  return kind_of(st.st_mode);
}

std::string_view describe(FileKind kind) {
  switch (kind) {
    case FileKind::Missing:
      return "nothing there";
    case FileKind::Regular:
      return "a regular file";
    case FileKind::Directory:
      return "a folder";
    case FileKind::Fifo:
      return "a FIFO (named pipe)";
    case FileKind::CharDevice:
      return "a character device";
    case FileKind::BlockDevice:
      return "a block device";
    case FileKind::Socket:
      return "a socket";
    case FileKind::Other:
      break;
  }
  return "not a file";
}

std::uintmax_t require_regular_file(const std::filesystem::path& path, std::string_view what,
                                    std::uintmax_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int error = errno;
    fail(path, what, error == ENOENT ? "file not found" : std::string("cannot read: ") + std::strerror(error));
  }
  check_stat(path, what, st, max_bytes);
  return static_cast<std::uintmax_t>(st.st_size);
}

namespace {

// Opens `path` for reading without blocking (a FIFO with no writer would block in open) and checks
// what was opened on its descriptor, so nothing can swap the file between the check and the read.
// Returns the descriptor and the size seen.
std::pair<int, std::uintmax_t> open_regular(const std::filesystem::path& path, std::string_view what,
                                            std::uintmax_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    const int error = errno;
    fail(path, what, error == ENOENT ? "file not found" : std::string("cannot open: ") + std::strerror(error));
  }
  Descriptor owner{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) fail(path, what, std::string("cannot read: ") + std::strerror(errno));
  check_stat(path, what, st, max_bytes);
  owner.fd = -1;
  return {fd, static_cast<std::uintmax_t>(st.st_size)};
}

}  // namespace

std::string read_file(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes) {
  const auto [fd, size] = open_regular(path, what, max_bytes);
  Descriptor file{fd};

  // Read up to one byte past the size seen, so a file that grows meanwhile is still bounded.
  std::string bytes(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  for (;;) {
    if (done == bytes.size()) {
      if (bytes.size() >= max_bytes) {
        char extra = 0;
        const ssize_t n = ::read(file.fd, &extra, 1);
        if (n > 0) fail(path, what, "grew past " + std::to_string(max_bytes) + " bytes while being read");
        break;
      }
      bytes.resize(std::min<std::uintmax_t>(max_bytes, bytes.size() + 4096));
    }
    const ssize_t n = ::read(file.fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(path, what, std::string("read failed: ") + std::strerror(errno));
    }
    if (n == 0) break;
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

// The line reader: one buffer of 64 KiB (or the line bound, if larger) refilled as lines are taken.
LineReader::LineReader(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes,
                       std::size_t max_line)
    : path_(path), what_(what), max_bytes_(max_bytes), max_line_(max_line) {
  fd_ = open_regular(path, what, max_bytes).first;
  buffer_.resize(std::max<std::size_t>(std::size_t{1} << 16, max_line_ + 1));
}

LineReader::~LineReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool LineReader::fill() {
  if (eof_) return false;
  // Keep the unread part at the front, then read after it.
  if (begin_ > 0) {
    std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>(begin_),
              buffer_.begin() + static_cast<std::ptrdiff_t>(end_), buffer_.begin());
    end_ -= begin_;
    begin_ = 0;
  }
  for (;;) {
    const ssize_t n = ::read(fd_, buffer_.data() + end_, buffer_.size() - end_);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(path_, what_, std::string("read failed: ") + std::strerror(errno));
    }
    if (n == 0) {
      eof_ = true;
      return false;
    }
    read_ += static_cast<std::uintmax_t>(n);
    if (read_ > max_bytes_)
      fail(path_, what_, "grew past " + std::to_string(max_bytes_) + " bytes while being read");
    end_ += static_cast<std::size_t>(n);
    return true;
  }
}

bool LineReader::next(std::string& line) {
  std::size_t scanned = begin_;
  for (;;) {
    // A complete line in the buffer: hand it out.
    const auto first = buffer_.begin() + static_cast<std::ptrdiff_t>(scanned);
    const auto last = buffer_.begin() + static_cast<std::ptrdiff_t>(end_);
    const auto newline = std::find(first, last, '\n');
    const std::size_t length = static_cast<std::size_t>(newline - buffer_.begin()) - begin_;
    if (length > max_line_)
      fail(path_, what_,
           "line " + std::to_string(line_number_ + 1) + " is longer than " + std::to_string(max_line_) +
               " bytes");
    if (newline != last) {
      line.assign(buffer_.data() + begin_, length);
      begin_ += length + 1;
      ++line_number_;
      return true;
    }
    // None yet: read more, or end with the unterminated last line.
    scanned = end_;
    const std::size_t kept = begin_;
    if (!fill()) {
      if (begin_ == end_) return false;
      line.assign(buffer_.data() + begin_, end_ - begin_);
      begin_ = end_;
      ++line_number_;
      return true;
    }
    scanned -= kept;  // fill() moved the unread part to the front
  }
}

}  // namespace cariesim::io
