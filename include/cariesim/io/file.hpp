#pragma once
/// Reading a file that may come from another machine: the one place that checks what a path names
/// before anything opens it. A FIFO, a device (/dev/zero), a socket or a folder is refused with its
/// kind, so a read never blocks forever or runs without end; a regular file is read up to a bound.
/// Every message starts with the path and says what the file was for ("scene", "trajectory").
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace cariesim::io {

/// Default bound of a text input (scene, study, course, answers, trajectory): 64 MiB.
inline constexpr std::uintmax_t kMaxTextBytes = std::uintmax_t{64} << 20;

/// Default bound of one line of a streamed text input (LineReader): 1 MiB.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

/// What a path names, as lstat/stat see it.
enum class FileKind { Missing, Regular, Directory, Fifo, CharDevice, BlockDevice, Socket, Other };

/// The kind of `path` (symbolic links followed); Missing when nothing is there.
FileKind file_kind(const std::filesystem::path& path);
/// "a FIFO (named pipe)", "a folder", "a character device" ...: the kind in words for messages.
std::string_view describe(FileKind kind);

/// Checks that `path` names a regular file of at most `max_bytes` bytes; throws cariesim::Error
/// "PATH: WHAT: not a regular file (a FIFO (named pipe))", "...: file not found", "...: too large
/// (N bytes, at most M)". Returns the file's size in bytes.
std::uintmax_t require_regular_file(const std::filesystem::path& path, std::string_view what,
                                    std::uintmax_t max_bytes = kMaxTextBytes);

/// The whole content of a regular file of at most `max_bytes` bytes. The file is opened without
/// blocking and checked on the open descriptor (no window between the check and the read); throws
/// cariesim::Error naming the path, `what` and the cause.
std::string read_file(const std::filesystem::path& path, std::string_view what,
                      std::uintmax_t max_bytes = kMaxTextBytes);

/// A text input read line by line (a trajectory CSV), so memory never holds its whole text: the
/// same checks as read_file when it opens (regular file, at most `max_bytes`, opened without
/// blocking and checked on the descriptor), then every line bounded by `max_line` bytes and the whole
/// read by `max_bytes` even if the file grows meanwhile. Errors are cariesim::Error naming the path,
/// `what` and, for a line, its number.
class LineReader {
 public:
  LineReader(const std::filesystem::path& path, std::string_view what,
             std::uintmax_t max_bytes = kMaxTextBytes, std::size_t max_line = kMaxLineBytes);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// The next line without its '\n' (a '\r' before it is kept, as std::getline keeps it); false at
  /// the end of the file. The last line needs no '\n'.
  bool next(std::string& line);
  /// The number of the line `next` returned last (1-based; 0 before the first).
  [[nodiscard]] std::size_t line_number() const { return line_number_; }

 private:
  // Refills buffer_ from the file; false at its end.
  bool fill();

  std::filesystem::path path_;
  std::string what_;
  std::uintmax_t max_bytes_;
  std::size_t max_line_;
  int fd_ = -1;
  std::vector<char> buffer_;
  std::size_t begin_ = 0, end_ = 0;
  std::uintmax_t read_ = 0;
  std::size_t line_number_ = 0;
  bool eof_ = false;
};

}  // namespace cariesim::io
