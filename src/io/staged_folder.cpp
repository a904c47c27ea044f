#include "cariesim/io/staged_folder.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

namespace fs = std::filesystem;

namespace {

// The process id in `name` when it is exactly PREFIX followed by a decimal pid, 0 otherwise.
pid_t staged_pid(const std::string& name, const std::string& prefix) {
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return 0;
  const char* first = name.data() + prefix.size();
  const char* last = name.data() + name.size();
  if (*first == '0') return 0;
  pid_t pid = 0;
  const auto [end, ec] = std::from_chars(first, last, pid);
  return ec == std::errc() && end == last && pid > 0 ? pid : 0;
}

// True when no process `pid` exists (one of another user still counts as alive).
bool process_gone(pid_t pid) { return ::kill(pid, 0) != 0 && errno == ESRCH; }

}  // namespace

std::vector<fs::path> remove_stale_staging(const fs::path& target, const std::string& what) {
  std::vector<fs::path> removed;
  const std::string prefix = "." + target.filename().string() + "." + what + "-";
  std::error_code ec;
  fs::directory_iterator it(target.parent_path().empty() ? fs::path(".") : target.parent_path(), ec);
  if (ec) return removed;
  // Only folders (not links) named exactly .NAME.WHAT-PID, of a process that no longer exists.
  for (const fs::directory_entry& entry : it) {
    const pid_t pid = staged_pid(entry.path().filename().string(), prefix);
    if (pid == 0 || pid == ::getpid() || !entry.is_directory(ec) || entry.is_symlink(ec) ||
        !process_gone(pid))
      continue;
    if (fs::remove_all(entry.path(), ec) != static_cast<std::uintmax_t>(-1) && !ec)
      removed.push_back(entry.path());
  }
  return removed;
}

StagedFolder::StagedFolder(const fs::path& target, const std::string& what) : what_(what) {
  fs::path t = target.lexically_normal();
  if (t.filename().empty()) t = t.parent_path();
  if (t.empty()) t = ".";
  std::error_code ec;
  if (fs::exists(t, ec) && !fs::is_directory(t, ec)) throw Error(t.string() + ": exists and is not a folder");
  target_ = fs::absolute(t, ec);
  if (ec) throw Error(t.string() + ": cannot resolve the " + what_ + " folder: " + ec.message());
  if (!target_.parent_path().empty()) {
    fs::create_directories(target_.parent_path(), ec);
    if (ec) throw Error(target_.string() + ": cannot create the " + what_ + " folder: " + ec.message());
  }
  // What a killed earlier run left beside the target goes first.
  removed_stale_ = remove_stale_staging(target_, what_);
  staging_ = target_.parent_path() / ("." + target_.filename().string() + "." + what_ + "-" + std::to_string(::getpid()));
  fs::remove_all(staging_, ec);
  if (!fs::create_directories(staging_, ec) || ec)
    throw Error(target_.string() + ": cannot create the " + what_ + "'s staging folder " + staging_.string() + ": " +
                (ec ? ec.message() : std::string("it exists")));
}

StagedFolder::~StagedFolder() {
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

std::vector<fs::path> StagedFolder::publish() {
  std::vector<fs::path> names;
  for (const fs::directory_entry& e : fs::directory_iterator(staging_)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  std::error_code ec;
  if (!fs::exists(target_, ec)) {
    fs::rename(staging_, target_, ec);
    if (ec) throw Error(target_.string() + ": cannot move the " + what_ + " into place: " + ec.message());
  } else {
    if (!fs::is_directory(target_, ec)) throw Error(target_.string() + ": exists and is not a folder");
    for (const fs::path& name : names) {
      fs::rename(staging_ / name, target_ / name, ec);
      if (ec) throw Error((target_ / name).string() + ": cannot move the " + what_ + " into place: " + ec.message());
    }
  }
  for (fs::path& name : names) name = target_ / name;
  return names;
}

}  // namespace cariesim::io
