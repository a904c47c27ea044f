#include "cariesim/io/staged_folder.hpp"

#include <unistd.h>

#include <algorithm>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

namespace fs = std::filesystem;

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
