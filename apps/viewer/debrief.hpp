#pragma once
/// The debrief screen of a diagnosis case (docs/training.md "Debrief", docs/instructors.md): the
/// case's lesions revealed, the trainee's marks drawn on the teeth (found, again, false, in the air),
/// the scores in words, the moments of insertion, and the replay of the case's recording with the
/// ghost tool. Shown after a case (the study file's `debrief:`) or by `cariesim review DB`. The data
/// is the training module's Debrief (cariesim/training/debrief.hpp); the window only draws it.

#include <filesystem>
#include <optional>
#include <string>

#include "cariesim/record/recorder.hpp"
#include "cariesim/training/debrief.hpp"

namespace cariesim::viewer {

/// One debrief the window shows or will show.
struct DebriefScreen {
  training::Debrief data;
  std::string title;                ///< "Trial 2 of 3", or "P01, trial 2 (row 7)" in a review
  std::filesystem::path recording;  ///< the case's recording, replayed with the ghost tool
  bool review = false;              ///< `cariesim review`: no Continue (closing the window ends it)
  /// The trial's scene, built again before the replay (a study's debriefs at its end, a review).
  std::string scene_yaml;
  std::string scene_origin;
  /// A review's trial as rebuilt, and its recording's session row: the built scene is checked
  /// against both (training::check_rebuilt_scene) before the replay starts.
  std::optional<training::RebuiltTrial> rebuilt;
  SessionInfo recorded;
};

/// "m:ss".
std::string debrief_clock(double seconds);

/// The panel line of a mark: "mark 2 at 0:14, severe: false mark (3.2 mm from the nearest lesion)".
std::string debrief_mark_line(const training::DebriefMark& mark);

}  // namespace cariesim::viewer
