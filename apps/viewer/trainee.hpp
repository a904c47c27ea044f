#pragma once
/// Trainee mode (docs/viewer.md, docs/instructors.md): what a trainee may see, the instructor's
/// passphrase lock over the full panel, and the script that drives the window in tests.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scene_view.hpp"

namespace cariesim::viewer {

/// The display settings a locked trainee window draws with: the tissues and the solid tool only. No
/// lesion colour, and none of the overlays that show the engine's state: force arrow, contacts,
/// virtual tunnel, sphere trees, haptic and recorded ghosts, the working end drawn over everything.
/// Soft-tissue dents stay (they show where the trainee presses gingiva or tongue, not lesions).
ViewSettings trainee_settings(const ViewSettings& settings);

/// The instructor's lock: the full panel opens for the passphrase whose hash the course file holds.
class InstructorLock {
 public:
  /// `hash`: the stored passphrase hash; empty: nothing unlocks (trainee mode without a course).
  explicit InstructorLock(std::string hash = {}) : hash_(std::move(hash)) {}
  /// Checks a passphrase (PBKDF2, ~0.16 s): true and unlocked when right; a wrong one is refused and
  /// counted.
  bool try_unlock(std::string_view passphrase);
  /// Back to trainee mode.
  void lock() { unlocked_ = false; }
  [[nodiscard]] bool unlocked() const { return unlocked_; }
  [[nodiscard]] bool can_unlock() const { return !hash_.empty(); }
  /// Wrong passphrases so far.
  [[nodiscard]] int refused() const { return refused_; }

 private:
  std::string hash_;
  bool unlocked_ = false;
  int refused_ = 0;
};

/// One step of a window script (`cariesim run --script FILE`): at `t` seconds of servo time of the
/// running session, an action with its argument.
struct ScriptStep {
  double t = 0.0;  ///< s, servo time of the running session
  /// key (press a key: a letter, a digit, or Enter/Space/Escape), passphrase (submit a passphrase
  /// to the instructor lock), lock (lock the full panel again)
  std::string action;
  std::string argument;  ///< the key's name, or the passphrase (the rest of the line)
  int line = 0;          ///< 1-based line in the file
};

/// Reads a window script: one step a line, `SECONDS ACTION [ARGUMENT]`, '#' starts a comment line,
/// times not decreasing. Throws cariesim::Error "file:line: message".
std::vector<ScriptStep> parse_script(std::string_view text, const std::string& file);
/// Reads a script file (parse_script); throws cariesim::Error for a missing file.
std::vector<ScriptStep> load_script(const std::string& file);
/// The GLFW key code of a script key name ("L", "3", "Enter", "Space", "Escape"); -1 when unknown.
int script_key_code(std::string_view name);

}  // namespace cariesim::viewer
