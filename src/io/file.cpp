#include "cariesim/io/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

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

std::string read_file(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes) {
  // Open without blocking (a FIFO with no writer would block here), then check what was opened.
  Descriptor file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY)};
  if (file.fd < 0) {
    const int error = errno;
    fail(path, what, error == ENOENT ? "file not found" : std::string("cannot open: ") + std::strerror(error));
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) fail(path, what, std::string("cannot read: ") + std::strerror(errno));
  check_stat(path, what, st, max_bytes);

  // Read up to one byte past the size seen, so a file that grows meanwhile is still bounded.
  std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
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

}  // namespace cariesim::io
