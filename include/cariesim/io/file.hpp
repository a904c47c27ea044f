#pragma once
/// Reading a file that may come from another machine: the one place that checks what a path names
/// before anything opens it. A FIFO, a device (/dev/zero), a socket or a folder is refused with its
/// kind, so a read never blocks forever or runs without end; a regular file is read up to a bound.
/// Every message starts with the path and says what the file was for ("scene", "trajectory").
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace cariesim::io {

/// Default bound of a text input (scene, study, course, answers, trajectory): 64 MiB.
inline constexpr std::uintmax_t kMaxTextBytes = std::uintmax_t{64} << 20;

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

}  // namespace cariesim::io
