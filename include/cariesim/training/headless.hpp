#pragma once
/// A whole study without a window (`cariesim study run`, docs/training.md): a scripted device drives
/// the servo loop of each trial through a Session that records it, and an answers file plays the
/// participant.
///
/// Answers file (YAML, strict like the study files; docs/training.md):
///
///   trials:
///     - tuning: {mild: {mu_s: 0.2, mu_d: 0.15}, severe: {mu_s: 0.5, mu_d: 0.45}}
///     - shapes: [circle, square, triangle]          # per cube, in cube order
///     - marks:                                     # diagnosis
///         - {t: 1.2, grade: severe}                # the recorded tip at t (s)
///         - {at: [0.0, 0.0, 6.9], t: 1.5, grade: mild}   # or an explicit tip position (mm)
///       buttons: {mild: 0, severe: 1}              # also: each press of device button 0 (1) in the
///                                                  # recording is a mild (severe) mark at the tip
///       end: 2.0                                   # ends the case at t (s); unset: when the path ends
///       device: scripted:other.csv                 # this trial's own device (default: --device)
///
/// Trial i of the run takes entry i (the last one repeats when there are fewer entries).

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::training {

/// A diagnosis mark in an answers file.
struct ScriptedMark {
  double t = 0.0;          ///< s, servo time of the press
  std::optional<Vec3> at;  ///< mm, world; unset: the recorded graphic tip at t (and its contact)
  Grade grade = Grade::Mild;
  bool contact = true;  ///< from the recording for a recorded tip; true for an explicit `at`
};

/// One trial's entry of an answers file.
struct ScriptedTrial {
  SourceLoc where;                                              ///< the entry in the answers file
  std::map<std::string, std::map<std::string, double>> tuning;  ///< level -> parameter -> value
  std::vector<std::string> shapes;
  std::vector<ScriptedMark> marks;
  /// Device buttons whose presses in the recording are marks (marks_from_buttons); -1: none.
  int mild_button = -1;
  int severe_button = -1;
  std::optional<double> end;  ///< s
  std::string device;         ///< empty: the run's device
};

/// A parsed answers file.
struct ScriptedAnswers {
  std::string origin;
  std::vector<ScriptedTrial> trials;
};

/// Parses an answers file; `origin` names it in messages and anchors relative device files. Throws
/// cariesim::Error "file:line:column: message".
ScriptedAnswers parse_answers(std::string_view yaml, const std::filesystem::path& origin);
/// Reads and parses an answers file.
ScriptedAnswers load_answers(const std::filesystem::path& file);

/// How a headless study runs.
struct HeadlessOptions {
  std::string device = "null";  ///< the device spec of every trial (scripted:FILE), unless its entry has one
  std::string device_profile;   ///< a hardware device's profile file (docs/devices.md); empty: default
  double duration = 0.0;        ///< s of servo time per trial when the device does not end; 0: 1 s
  bool realtime = false;        ///< ask for SCHED_FIFO
  BuildOptions build;           ///< how to build each trial's scene
  /// Called after each trial (e.g. to print a line).
  std::function<void(const TrialResult&)> on_trial;
};

/// Runs every trial of `run` (from its current one): builds the scene, runs a recorded Session with the
/// device until the path ends (or the case's end or time limit), gives the answers and ends the
/// trial; a hardware device's buttons (its profile's mark_mild, mark_severe, end_case) also mark and
/// end a diagnosis case. Returns the results. Throws cariesim::Error naming the trial and what failed.
std::vector<TrialResult> run_headless(StudyRun& run, const ScriptedAnswers& answers,
                                      const HeadlessOptions& options);

}  // namespace cariesim::training
