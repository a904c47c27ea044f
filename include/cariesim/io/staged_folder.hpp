#pragma once
// An output folder written all or nothing: files go into a hidden staging sibling of the target (same
// file system) and move into the target by rename only when complete, so a failed write leaves an
// earlier output as it was. Used by `cariesim export` (record) and `cariesim report` (training).
#include <filesystem>
#include <string>
#include <vector>

namespace cariesim::io {

class StagedFolder {
 public:
  /// Checks `target` (a folder or nothing yet; its parents are created) and creates the staging
  /// folder beside it. `what` names the output in errors ("export", "report"). Throws cariesim::Error
  /// naming the folder.
  StagedFolder(const std::filesystem::path& target, const std::string& what);
  /// Removes the staging folder and whatever is left in it.
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  /// Where to write the files.
  [[nodiscard]] const std::filesystem::path& staging() const { return staging_; }
  /// The absolute target folder.
  [[nodiscard]] const std::filesystem::path& target() const { return target_; }
  /// Moves every staged file into the target: the whole folder by one rename when the target does not
  /// exist yet, otherwise file by file (each rename replaces one earlier file at once). Returns the
  /// files' paths in the target, sorted. Throws cariesim::Error naming the file that could not move.
  std::vector<std::filesystem::path> publish();

 private:
  std::filesystem::path target_;
  std::filesystem::path staging_;
  std::string what_;
};

}  // namespace cariesim::io
