#pragma once
/// Trainee mode (docs/viewer.md, docs/instructors.md): what a trainee may see, the instructor's
/// passphrase lock over the full panel, and the script that drives the window in tests.

#include <chrono>
#include <functional>
#include <future>
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
///
/// A passphrase is checked on a worker thread (PBKDF2 takes up to kPassphraseMaxIterations' worth,
/// about 0.5 s), so the window keeps drawing and says "checking"; the UI thread collects the outcome
/// with poll() each frame. After kFreeTries wrong passphrases in a row each further try waits
/// (backoff_seconds: 1 s, then 2, 4, ... at most kMaxBackoff) from the end of the last wrong one;
/// a try in that time is refused unchecked. A right passphrase starts the count over.
class InstructorLock {
 public:
  using Clock = std::chrono::steady_clock;
  /// Wrong passphrases in a row before the tries are spaced out.
  static constexpr int kFreeTries = 3;
  /// s, the longest wait between two tries.
  static constexpr double kMaxBackoff = 300.0;

  /// `hash`: the stored passphrase hash; empty: nothing unlocks (trainee mode without a course).
  /// `now`: the clock of the back-off (tests give their own).
  explicit InstructorLock(std::string hash = {}, std::function<Clock::time_point()> now = Clock::now);
  /// Waits for a check in flight.
  ~InstructorLock();
  InstructorLock(InstructorLock&&) noexcept;
  InstructorLock& operator=(InstructorLock&&) noexcept;

  /// What submit() did.
  enum class Submitted {
    Checking,  ///< the check runs on the worker; poll() gives its outcome
    Busy,      ///< a check is already running: nothing done
    Wait,      ///< within the back-off after wrong passphrases: refused unchecked (wait_seconds())
    NoHash,    ///< this window has no passphrase (no course): refused and counted
  };
  /// Starts checking a passphrase on the worker thread and returns at once.
  Submitted submit(std::string passphrase);
  /// Collects a finished check (call every frame): true unlocked, false refused (counted), unset
  /// when no check finished since the last call.
  std::optional<bool> poll();
  /// Blocks until the check in flight (if any) ends, then poll() (tests, shutdown).
  std::optional<bool> wait();
  /// Back to trainee mode.
  void lock() { unlocked_ = false; }
  [[nodiscard]] bool unlocked() const { return unlocked_; }
  [[nodiscard]] bool can_unlock() const { return !hash_.empty(); }
  /// True while a passphrase is being checked.
  [[nodiscard]] bool checking() const { return pending_.valid(); }
  /// Wrong passphrases so far (all, not only those in a row).
  [[nodiscard]] int refused() const { return refused_; }
  /// Tries refused unchecked because they came within the back-off.
  [[nodiscard]] int deferred() const { return deferred_; }
  /// s until the next try is checked (0: now).
  [[nodiscard]] double wait_seconds() const;
  /// s a try must wait after `failures` wrong passphrases in a row: 0 below kFreeTries, then
  /// 2^(failures - kFreeTries), at most kMaxBackoff.
  static double backoff_seconds(int failures);

 private:
  std::string hash_;
  std::function<Clock::time_point()> now_;
  std::future<bool> pending_;
  bool unlocked_ = false;
  int refused_ = 0;
  int failures_ = 0;  // wrong in a row
  int deferred_ = 0;
  Clock::time_point next_try_{};  // no try is checked before this
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
