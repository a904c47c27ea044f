#pragma once
/// The interactive simulator (`cariesim run`, docs/design.md §5): a GLFW window with OpenGL 3.3 core and
/// Dear ImGui, the servo loop on its own thread, a device (the mouse by default), optionally a
/// session record. docs/viewer.md describes what the user sees and the controls.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/servo/servo.hpp"

namespace cariesim::viewer {

struct ViewerOptions {
  std::string scene = "real-arch";  ///< built-in scene name or scene YAML file
  /// `--set` overrides of `scene` and of a course's trial scenes (docs/scene-format.md, "Overrides")
  std::vector<SceneOverride> overrides;
  std::string device_profile;       ///< a hardware device's profile file (docs/devices.md); empty: default
  std::string device = "mouse";     ///< mouse | null | scripted:FILE[:loop] | replay:FILE | udp:PORT[:HOST]
  double rate_hz = 0.0;             ///< Hz, servo rate; 0: the scene's
  std::string record;               ///< SQLite file for the session record; empty: none
  bool overwrite = false;           ///< replace an existing record file (otherwise it is an error)
  std::string screenshot;           ///< PNG written after `exit_after`; empty: none
  double exit_after = 0.0;          ///< s of servo time after which the viewer exits; 0: never
  bool show_lesions = false;        ///< start with the lesions revealed (hidden is a trial's default)
  bool realtime = true;             ///< ask for real-time priority for the servo thread
  double spin_us = kDefaultSpinUs;  ///< µs the servo thread polls before each deadline (ServoOptions)
  bool standby = true;              ///< a standby servo thread on a second CPU (ServoOptions)
  int width = 1280;                 ///< px, window width
  int height = 800;                 ///< px, window height
  /// Camera preset on the explorer's tip once it is drawn (occlusal | buccal | lingual | operator);
  /// empty: the whole scene framed
  std::string view;
  /// Trainee mode (docs/instructors.md): nothing on screen gives a lesion away (no lesion colour or
  /// panel, no state or depth readout, no overlays, no reveal key); a course implies it
  bool trainee = false;
  std::string course;       ///< course file: trainee mode running the course's study; empty: none
  std::string participant;  ///< participant ID for the course's study; empty: asked in the window
  std::string station;      ///< overrides the course file's station name; empty: the course's
  /// Answers file that plays the participant of the course's study (the format of `cariesim study
  /// run --answers`, docs/training.md); empty: the participant answers in the panel
  std::string answers;
  std::optional<int> trials;     ///< overrides the course study's trial count
  std::optional<uint64_t> seed;  ///< the course study's seed; unset: the study file's, else drawn
  /// Window script for automation (docs/viewer.md): timed key presses and passphrases; empty: none
  std::string script;
  /// `cariesim review`: a study database whose trial's debrief the window shows (docs/training.md,
  /// "Debrief"); empty: none. The participant (empty: the only one) and the trial number (unset:
  /// their last ended trial) choose the trial.
  std::string review;
  std::string review_participant;
  std::optional<int> review_trial;
};

/// True when a window system is reachable (DISPLAY or WAYLAND_DISPLAY is set).
bool display_available();

/// What to tell a user without a display: why, and how to run under Xvfb instead.
std::string headless_message();

/// Opens the window on the scene and runs until it is closed (or `exit_after` passes). Returns the
/// process exit status: 0 done; throws cariesim::Error for bad input (scene, device, files) and when
/// no window can be opened.
int run_viewer(const ViewerOptions& options);

}  // namespace cariesim::viewer
