#pragma once
/// The viewer application behind run_viewer (viewer.hpp): the window, sessions (model + device +
/// servo loop + record), the scene builder thread, input, drawing, the ImGui panel, exit and
/// screenshot. Internal to apps/viewer.

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "camera.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/replay.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/servo/session.hpp"
#include "cariesim/training/course.hpp"
#include "cariesim/training/headless.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"
#include "debrief.hpp"
#include "force_history.hpp"
#include "gl_renderer.hpp"
#include "mouse_device.hpp"
#include "scene_view.hpp"
#include "trainee.hpp"
#include "viewer.hpp"

struct GLFWwindow;
struct ImVec4;

namespace cariesim::io {
class JsonWriter;
}

namespace cariesim::viewer {

/// A model being simulated: the runtime's Session on it (device, servo loop, record; the running
/// Params as the servo thread publishes them) and what the viewer draws of it. Members are declared
/// so that destruction stops the session before the model goes.
struct SceneSession {
  std::string source;  ///< scene name or file it was built from
  std::unique_ptr<Model> model;
  /// The answers file's mark times, taken by the servo thread (declared before `run`: it outlives it)
  std::unique_ptr<TimedCapture> capture;
  std::unique_ptr<Session> run;    ///< device, servo loop and record
  MouseDevice* mouse = nullptr;    ///< the device when it is the mouse
  ReplayDevice* replay = nullptr;  ///< the device when it is a replay (device/replay.hpp)
  HapticDevice* haptic = nullptr;  ///< the device when it is a hardware device (touch, fd, haply)
  std::unique_ptr<SceneView> view;
  ~SceneSession();
  /// Stops the servo loop, then the recorder (idempotent).
  void stop();
};

/// A scene being built on a worker thread.
struct PendingBuild {
  std::string source;
  bool trial = false;  ///< the scene of the course study's current trial (its session records the trial)
  std::string key;     ///< a trial's scene (origin and text): whether a build begun ahead is that trial's
  std::future<std::unique_ptr<Model>> result;
  std::mutex mutex;  // guards `stage` (worker and UI thread; never the servo thread)
  std::string stage;
  std::atomic<double> fraction{0.0};
};

/// What the panel keeps between frames.
struct PanelState {
  int lesion = 0;          ///< selected lesion
  int builtin = 0;         ///< selected built-in scene
  std::string scene_path;  ///< the scene-file text field
  std::string save_path;   ///< where a built-in scene is saved
  std::string message;     ///< the last action's outcome
  bool message_is_error = false;
  float force_scale = 1.0f;          ///< global force scale, in [0, 1]
  float x = 0, y = 0, w = 0, h = 0;  ///< px, where the panel window was drawn last
  float scroll_max = 0;              ///< px, how far its content scrolls (0: it fits)
  float overflow_x = 0;              ///< px, how far its widest line reaches past its right edge (0: none)
};

class ViewerApp {
 public:
  explicit ViewerApp(const ViewerOptions& options);
  ~ViewerApp();
  ViewerApp(const ViewerApp&) = delete;
  ViewerApp& operator=(const ViewerApp&) = delete;
  /// Runs until the window closes or exit_after passes; returns the exit status.
  int run();

 private:
  // Window and GL (viewer.cpp).
  void open_window();
  // Sessions (viewer.cpp).
  void request_build(const std::string& source);
  /// Builds a scene that `load` describes (on the worker thread); `label` names it in messages.
  void request_build(const std::string& label, std::function<SceneDesc()> load, bool trial);
  /// Starts building on a worker thread (at a lower CPU priority when `background`) and returns it.
  std::unique_ptr<PendingBuild> start_build(const std::string& label, std::function<SceneDesc()> load,
                                            bool trial, bool background);
  /// Begins building the next trial's scene in the background while the current trial runs.
  void prepare_next_trial();
  /// Drops the builds begun ahead that were not used, once their workers finished (every frame).
  void reap_builds();
  void poll_build();
  /// Starts a session on `model`; its device is next_device_ when set (once), else the options'.
  void start_session(std::unique_ptr<Model> model, const std::string& source, bool trial = false);
  void restart_servo();
  // Frame work (viewer.cpp).
  void handle_input();
  void read_snapshot();
  void draw_scene(int width, int height);
  void finish(int width, int height);
  void print_summary() const;
  // Panel (panel.cpp).
  void draw_panel();
  void draw_build_progress();
  void panel_scene();
  void panel_status();
  void panel_plots();
  void panel_view();
  void panel_lesion();
  void panel_camera();
  void panel_trainee();
  void panel_instructor();
  /// A collapsing section of the panel, open by default; its name is noted for the status file.
  bool section(const char* name);
  void post(const ParamChange& change);
  void save_scene();
  [[nodiscard]] std::string status_json(int width, int height) const;

  ViewerOptions options_;
  GLFWwindow* window_ = nullptr;
  bool imgui_ready_ = false;
  std::unique_ptr<GlRenderer> renderer_;
  OrbitCamera camera_;
  MouseControl control_;
  ViewSettings settings_;
  ForceHistory history_;
  std::unique_ptr<SceneSession> session_;
  std::unique_ptr<PendingBuild> build_;
  std::unique_ptr<PendingBuild> next_build_;                 // the next trial's scene, built ahead
  std::vector<std::unique_ptr<PendingBuild>> stale_builds_;  // built ahead, not used, still running
  std::string build_error_;
  bool record_used_ = false;  // --record covers the first session only
  ServoSnapshot snapshot_;
  bool have_snapshot_ = false;
  TimingReport timing_;  // refreshed about once a second
  std::chrono::steady_clock::time_point timing_refreshed_{};
  std::vector<DeviceCounter> counters_;
  PanelState panel_;
  std::vector<float> plot_scratch_;
  int view_width_ = 0;  // px, the 3-D view's width (the panel takes the rest of the window)
  // Camera presets (camera.hpp): the one last chosen, one waiting for the first snapshot, and whether
  // the camera keeps the explorer's tip at the centre.
  std::optional<CameraPreset> preset_;
  std::optional<CameraPreset> pending_preset_;
  bool follow_tip_ = false;
  void apply_preset(CameraPreset preset);
  /// The graphic tool's sections (world), for the camera's line of sight past the handle.
  [[nodiscard]] std::vector<ToolSection> tool_sections() const;

  // Trainee mode (trainee.hpp): on or not, the course, the instructor's lock, the panel's
  // passphrase field and the outcome of the last attempt.
  bool trainee_ = false;
  std::optional<training::Course> course_;
  InstructorLock lock_;
  std::string passphrase_input_;
  std::string lock_message_;
  /// True while the window shows a trainee what a trainee may see.
  [[nodiscard]] bool locked() const { return trainee_ && !lock_.unlocked(); }
  /// What the scene is drawn with: the panel's settings, or trainee_settings() of them when locked.
  [[nodiscard]] ViewSettings shown_settings() const;
  void submit_passphrase(const std::string& passphrase);
  /// Collects the outcome of a passphrase check that finished (every frame).
  void poll_lock();
  std::vector<std::string> sections_;  // the panel's sections drawn in the last frame

  // The course's study (study_panel.cpp): the study and its run for the participant, what the panel
  // holds for the current trial (tuning sliders, shapes named, the grade of the next mark), the
  // answers file that plays the participant (--answers), the trials ended.
  std::optional<training::Study> study_;
  std::unique_ptr<training::StudyRun> run_;
  std::string participant_input_;
  std::string study_message_;
  bool study_message_is_error_ = false;
  std::map<std::string, double> tuning_values_;  // parameter name -> slider value (its unit)
  int tuned_lesion_ = -1;                        // the model's lesion the sliders change
  std::vector<int> shape_choice_;                // per cube: index into shape_choices, -1: not named
  int grade_choice_ = 0;                         // the next mark's grade: 0 mild, 1 severe
  std::array<float, 4> grade_box_{};             // px, x y w h of the chosen grade in the last frame
  uint32_t previous_buttons_ = 0;                // device buttons in the last snapshot
  uint32_t previous_actions_ = 0;                // device actions (DeviceAction) in the last snapshot
  bool device_seen_valid_ = false;               // the trial's device gave a valid reading
  std::optional<training::ScriptedAnswers> answers_;
  std::size_t answer_mark_next_ = 0;  // next of answer_order_ to mark
  std::vector<std::size_t>
      answer_order_;  // the trial's entry's marks by time (SceneSession::capture's order)
  std::vector<training::TrialResult> results_;
  [[nodiscard]] bool study_finished() const { return run_ && run_->finished(); }
  [[nodiscard]] bool trial_live() const;
  /// True while a diagnosis case takes marks (keys 1 and 2 then choose the grade).
  [[nodiscard]] bool diagnosis_live() const;
  /// The last trial problem in full (it may name the case): for the unlocked instructor's panel.
  std::string problem_detail_;
  /// A trial problem: its detail to problem_detail_, and to stderr unless in trainee mode.
  void note_problem(const std::string& detail);
  void start_study(const std::string& participant);
  void begin_trial();
  void end_trial();
  void study_frame();
  void panel_device();
  void study_mark(std::optional<training::Grade> grade = std::nullopt);
  void reset_tuning_sliders();
  void confirm_tuning();
  void submit_shapes();
  void play_answers();
  void panel_study();
  /// The grade of the next mark, large (keys 1 and 2, or a click, choose it).
  void panel_grade();
  void study_json(io::JsonWriter& json) const;

  // The debrief (debrief.cpp): the one shown, those waiting (a study's `debrief: at-end`), and the
  // device of the next session (the replay of a case's recording).
  std::unique_ptr<DebriefScreen> debrief_;
  std::vector<DebriefScreen> debrief_queue_;
  std::string next_device_;
  /// After a trial ends: opens (or queues) its debrief when the study asks for one; true when the
  /// window now shows a debrief (the next trial begins when it is continued).
  bool open_case_debrief(const training::TrialResult& result, const Model* model);
  void show_next_debrief();
  void start_review();
  void check_debrief_scene(const Model& model) const;
  [[nodiscard]] bool debrief_replay_done() const;
  void continue_after_debrief();
  /// Whether a debrief or a case follows the one shown (its button says Continue, else Done).
  [[nodiscard]] bool debrief_has_more() const;
  /// The debrief's Continue or Done, from its button or the Enter key (the stylus stays in hand).
  void debrief_go_on();
  void debrief_frame();
  void panel_debrief();
  void draw_debrief_overlay(int height);
  void debrief_json(io::JsonWriter& json) const;

  // The window script (--script): its steps, the next one, a key it pressed in the last frame.
  std::vector<ScriptStep> script_;
  std::size_t script_next_ = 0;
  int script_key_down_ = -1;
  void run_script();
};

/// ImGui::SameLine() when an item labelled `label` (a button's frame, plus `extra` px) still fits on
/// the current line of the panel; otherwise the item starts a new line.
void same_line_if_fits(const char* label, float extra = 0.0f);

/// Text in `color`, wrapped at the panel's right edge.
void wrapped(const ImVec4& color, const std::string& text);
/// The colour of ImGui's disabled text.
ImVec4 disabled_color();

/// px, width of the panel docked at the window's right edge.
inline constexpr float kPanelWidth = 400.0f;

}  // namespace cariesim::viewer
