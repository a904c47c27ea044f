#pragma once
// An output folder written all or nothing: files go into a hidden staging sibling of the target (same
// file system) and move into the target by rename only when complete, so a failed write leaves an
// earlier output as it was. Used by `cariesim export` (record) and `cariesim report` (training). The
// staging folder is ".NAME.WHAT-PID" beside the target; one left by a killed run (its process no
// longer exists) is removed by the next run for the same target.
#include <filesystem>
#include <string>
#include <vector>

namespace cariesim::io {

/// Removes the staging folders beside `target` that a killed run left: folders (not links) named
/// exactly ".NAME.WHAT-PID" for this target's NAME and `what`, whose process PID no longer exists.
/// Anything else, and a folder it cannot remove, is left as it is. Returns the folders removed.
std::vector<std::filesystem::path> remove_stale_staging(const std::filesystem::path& target,
                                                        const std::string& what);

class StagedFolder {
 public:
  /// Checks `target` (a folder or nothing yet; its parents are created), removes stale staging
  /// folders of killed runs (remove_stale_staging) and creates the staging folder beside it. `what`
  /// names the output in errors ("export", "report"). Throws cariesim::Error naming the folder.
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
  /// The stale staging folders the constructor removed.
  [[nodiscard]] const std::vector<std::filesystem::path>& removed_stale() const { return removed_stale_; }

 private:
  std::filesystem::path target_;
  std::filesystem::path staging_;
  std::string what_;
  std::vector<std::filesystem::path> removed_stale_;
};

}  // namespace cariesim::io
