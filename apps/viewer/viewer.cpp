#include "viewer.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <epoxy/gl.h>
#include <fmt/format.h>
#include <imgui.h>
#include <imgui/backends/imgui_impl_glfw.h>
#include <imgui/backends/imgui_impl_opengl3.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/record/replay.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/course.hpp"
#include "screenshot.hpp"
#include "viewer_app.hpp"

namespace cariesim::viewer {

namespace {

constexpr double kFramePeriod = 1.0 / 60.0;  // s, the display rate the loop paces itself to

// The last GLFW error, for messages.
std::string& glfw_error() {
  static std::string error;
  return error;
}

void on_glfw_error(int code, const char* description) {
  glfw_error() = fmt::format("GLFW error {}: {}", code, description != nullptr ? description : "");
}

// FILE.png -> FILE.json.
std::filesystem::path status_path(const std::filesystem::path& screenshot) {
  std::filesystem::path p = screenshot;
  p.replace_extension(".json");
  return p;
}

}  // namespace

bool display_available() {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  return (x11 != nullptr && *x11 != '\0') || (wayland != nullptr && *wayland != '\0');
}

std::string headless_message() {
  return "cariesim run needs a display for its window, and DISPLAY is not set (no X11 or Wayland "
         "session).\n"
         "On a headless machine run it under a virtual X server, for example:\n"
         "  xvfb-run -a -s \"-screen 0 1280x800x24\" cariesim run --screenshot run.png --exit-after 5\n"
         "(xvfb-run is in Debian's xvfb package; scripts/run does this by itself when there is no "
         "display).\n";
}

SceneSession::~SceneSession() { stop(); }

void SceneSession::stop() {
  if (run) run->stop();
}

ViewerApp::ViewerApp(const ViewerOptions& options) : options_(options) {
  // Bad input fails before any window opens: the scene must parse, the device spec must make a device,
  // an existing record file needs --overwrite.
  (void)load_scene(options_.scene, options_.overrides);
  if (!options_.record.empty() && !options_.overwrite && std::filesystem::exists(options_.record))
    throw Error(options_.record + ": the record file exists (--overwrite replaces it)");
  register_replay_device();
  if (options_.device != "mouse") (void)make_device(options_.device);
  settings_.show_lesions = options_.show_lesions;

  // Trainee mode: with a course, its instructor's passphrase opens the full panel; the lesions start
  // hidden whatever was asked.
  trainee_ = options_.trainee || !options_.course.empty();
  if (!options_.course.empty()) {
    course_ = training::load_course(options_.course);
    if (!options_.station.empty()) {
      if (!training::valid_identifier(options_.station))
        throw Error("station '" + options_.station + "': not a valid name (letters, digits, '.', '_', '-')");
      course_->station = options_.station;
    }
    if (!options_.participant.empty() && !course_->allows(options_.participant))
      throw Error("participant '" + options_.participant + "': not a valid ID" +
                  (course_->participants.empty() ? "" : " on the course's list (" + options_.course + ")"));
    lock_ = InstructorLock(course_->instructor_hash);
    // The study, and the answers file that may play the participant, checked before the window opens.
    try {
      study_ = training::load_study(course_->study);
    } catch (const Error& e) {
      throw Error(options_.course + ": study '" + course_->study + "': " + e.what());
    }
    if (!options_.answers.empty()) answers_ = training::load_answers(options_.answers);
  }
  if (trainee_) settings_.show_lesions = false;
  if (!options_.script.empty()) script_ = load_script(options_.script);
  if (!options_.view.empty()) {
    CameraPreset preset;
    if (!parse_preset(options_.view, preset))
      throw Error("view '" + options_.view + "': not one of occlusal, buccal, lingual, operator");
    pending_preset_ = preset;
    follow_tip_ = true;
  }
}

ViewerApp::~ViewerApp() {
  // The servo loop stops before its device and model go; GL objects go while the context lives.
  session_.reset();
  if (build_ && build_->result.valid()) build_->result.wait();
  build_.reset();
  if (next_build_) stale_builds_.push_back(std::move(next_build_));
  for (const auto& b : stale_builds_)
    if (b->result.valid()) b->result.wait();
  stale_builds_.clear();
  renderer_.reset();
  if (imgui_ready_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  if (window_ != nullptr) glfwDestroyWindow(window_);
  glfwTerminate();
}

void ViewerApp::open_window() {
  // GLFW with an OpenGL 3.3 core context.
  glfwSetErrorCallback(on_glfw_error);
  if (glfwInit() != GLFW_TRUE)
    throw Error(fmt::format("cannot initialise GLFW ({}).\n{}", glfw_error(), headless_message()));
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);  // the view and the docked panel follow the window's size
  window_ = glfwCreateWindow(options_.width, options_.height, "cariesim", nullptr, nullptr);
  if (window_ == nullptr)
    throw Error(fmt::format("cannot open an OpenGL 3.3 core window ({})", glfw_error()));
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(1);

  // Dear ImGui on GLFW and OpenGL 3; no imgui.ini in the working directory.
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  imgui_ready_ = true;
  renderer_ = std::make_unique<GlRenderer>();
}

void ViewerApp::request_build(const std::string& source) {
  // The command line's scene with its --set overrides; another scene loaded from the panel as it is.
  const std::vector<SceneOverride> overrides = source == options_.scene ? options_.overrides : std::vector<SceneOverride>{};
  request_build(
      source, [source, overrides] { return load_scene(source, overrides); }, false);
}

void ViewerApp::request_build(const std::string& label, std::function<SceneDesc()> load, bool trial) {
  // Parse and build on a worker thread; progress goes to the panel.
  build_error_.clear();
  build_ = start_build(label, std::move(load), trial, false);
  std::fprintf(stderr, "run: building %s\n", label.c_str());
}

std::unique_ptr<PendingBuild> ViewerApp::start_build(const std::string& label,
                                                     std::function<SceneDesc()> load, bool trial,
                                                     bool background) {
  auto build = std::make_unique<PendingBuild>();
  build->source = label;
  build->trial = trial;
  PendingBuild* pending = build.get();
  // In trainee mode no part of an object with lesions goes into the station's tree cache. A build
  // ahead runs niced, so that the window (and the servo thread, real-time anyway) keep their cores.
  pending->result =
      std::async(std::launch::async, [pending, load = std::move(load), trainee = trainee_, background] {
        if (background) (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), 10);
        const SceneDesc desc = load();
        BuildOptions options;
        options.cache_lesion_parts = !trainee;
        options.progress = [pending](std::string_view stage, double fraction) {
          const std::lock_guard lock(pending->mutex);
          pending->stage = std::string(stage);
          pending->fraction.store(fraction);
        };
        return std::make_unique<Model>(build_model(desc, options));
      });
  return build;
}

void ViewerApp::prepare_next_trial() {
  // The next trial's scene (as begin_trial will make it), built while the trainee works on this one.
  if (!run_ || next_build_ || run_->current_trial() + 1 >= run_->trial_count()) return;
  training::TrialSetup next;
  try {
    next = run_->trial_setup(run_->current_trial() + 1);
  } catch (const Error&) {
    return;  // begin_trial meets the same problem and reports it
  }
  const std::string label = fmt::format("trial {} of {}", next.index + 1, run_->trial_count());
  next_build_ = start_build(
      label, [next] { return next.scene(); }, true, true);
  next_build_->key = next.scene_origin + "\n" + next.scene_yaml;
  std::fprintf(stderr, "run: building %s in the background\n", label.c_str());
}

void ViewerApp::reap_builds() {
  // A build whose future is ready can go (its worker no longer touches it).
  std::erase_if(stale_builds_, [](const std::unique_ptr<PendingBuild>& b) {
    return !b->result.valid() || b->result.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  });
}

void ViewerApp::poll_build() {
  if (!build_ || build_->result.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  // The build finished: start a session on it, or report why it failed (fatal for the first scene).
  std::unique_ptr<PendingBuild> done = std::move(build_);
  try {
    std::unique_ptr<Model> model = done->result.get();
    // The part count gives the lesion count away: not in trainee mode.
    if (trainee_)
      std::fprintf(stderr, "run: %s ready\n", done->source.c_str());
    else
      std::fprintf(stderr, "run: %s ready (%zu collision parts)\n", done->source.c_str(),
                   model->objects.size());
    check_debrief_scene(*model);
    start_session(std::move(model), done->source, done->trial);
    if (done->trial) prepare_next_trial();
  } catch (const Error& e) {
    // A trial's scene that cannot be built or run leaves that trial unfinished (its row keeps
    // ended_at NULL); otherwise the first scene's failure is fatal.
    if (done->trial && run_) {
      // The reason may name the trial's hidden parts: a trainee is only told to call the instructor.
      study_message_ = locked() ? std::string("This trial could not start; please call the instructor.")
                                : std::string("This trial could not start: ") + e.what();
      study_message_is_error_ = true;
      note_problem(fmt::format("trial {} could not start: {}", run_->current_trial() + 1, e.what()));
      run_->abandon_trial(e.what());
      if (!run_->finished()) begin_trial();
      return;
    }
    if (!session_) throw;
    build_error_ = e.what();
  }
}

void ViewerApp::start_session(std::unique_ptr<Model> model, const std::string& source, bool trial) {
  // The old loop stops first; its view holds GL objects, freed here on the render thread.
  const bool same_scene = session_ && session_->source == source;
  if (session_) session_->stop();
  session_.reset();

  // The runtime's session: the mouse is composed here, every other device comes from its spec. The
  // record (--record) covers the first session; a scene change ends it.
  auto s = std::make_unique<SceneSession>();
  s->source = source;
  s->model = std::move(model);
  SessionOptions session_options;
  session_options.scene = source;
  session_options.device = next_device_.empty() ? options_.device : next_device_;
  next_device_.clear();
  session_options.device_profile = options_.device_profile;
  session_options.rate_hz = options_.rate_hz;
  session_options.realtime = options_.realtime;
  session_options.spin_us = options_.spin_us;
  session_options.standby = options_.standby;
  if (trial && run_) {
    // A study trial records itself where the run says; an answers entry may give its own device.
    session_options.record = run_->recording_path().string();
    // Held in memory until the trial's session stops: its lesion parameters and the samples' lesion
    // column are not on disk while the trainee probes.
    session_options.recorder.hold_until_stop = true;
    answer_order_.clear();
    if (answers_ && !answers_->trials.empty()) {
      const auto& entries = answers_->trials;
      const auto& entry = entries[std::min<std::size_t>(run_->current_trial(), entries.size() - 1)];
      if (!entry.device.empty()) session_options.device = entry.device;
      // Its marks by time; the servo thread takes the tip at each one's servo time (play_answers).
      answer_order_.resize(entry.marks.size());
      for (std::size_t i = 0; i < answer_order_.size(); ++i) answer_order_[i] = i;
      std::stable_sort(answer_order_.begin(), answer_order_.end(), [&entry](std::size_t a, std::size_t b) {
        return entry.marks[a].t < entry.marks[b].t;
      });
      std::vector<double> times;
      for (const std::size_t i : answer_order_) times.push_back(entry.marks[i].t);
      s->capture = std::make_unique<TimedCapture>(std::move(times));
      session_options.capture = s->capture.get();
    }
  } else if (!options_.record.empty() && !record_used_) {
    session_options.record = options_.record;
    session_options.recorder.overwrite = options_.overwrite;
    record_used_ = true;
  } else if (record_used_) {
    panel_.message = "The record ended with the previous scene (" + options_.record + ").";
    panel_.message_is_error = false;
  }
  if (session_options.device == "mouse")
    s->run = std::make_unique<Session>(
        *s->model, std::make_unique<MouseDevice>(s->model->tool_home, s->model->defaults.limits),
        session_options);
  else
    s->run = std::make_unique<Session>(*s->model, session_options);
  s->mouse = dynamic_cast<MouseDevice*>(&s->run->device());
  s->replay = dynamic_cast<ReplayDevice*>(&s->run->device());
  s->haptic = dynamic_cast<HapticDevice*>(&s->run->device());
  s->view = std::make_unique<SceneView>(*s->model);

  // The view: framed on a new scene, the mouse target at the tool's home.
  if (!same_scene) camera_.frame(s->view->bounds());
  control_.reset(s->model->tool_home);
  control_.workspace = s->model->defaults.limits.workspace;
  panel_.lesion = 0;
  const std::vector<std::string> names = builtin_scene_names();
  const auto builtin = std::find(names.begin(), names.end(), source);
  if (builtin != names.end()) panel_.builtin = static_cast<int>(builtin - names.begin());
  session_ = std::move(s);
  session_->run->start();
  have_snapshot_ = false;
  history_.clear();
  timing_ = TimingReport{};
  timing_refreshed_ = std::chrono::steady_clock::now();
  // A trial's panel starts over: sliders at their drawn start (sent to the servo thread), no shape
  // named, the device's buttons as they are.
  if (trial && run_) {
    previous_buttons_ = 0;
    previous_actions_ = 0;
    device_seen_valid_ = false;
    answer_mark_next_ = 0;
    shape_choice_.assign(run_->setup().cubes.size(), -1);
    tuned_lesion_ = -1;
    for (std::size_t i = 0; i < session_->model->lesions.size(); ++i)
      if (session_->model->lesions[i].name == run_->setup().tuned_lesion) tuned_lesion_ = static_cast<int>(i);
    reset_tuning_sliders();
  }
}

void ViewerApp::restart_servo() {
  // A fresh engine state on the session's model and device (the tuned Params kept), the mouse back
  // at home. Not while recording: the record's servo clock would start over.
  SceneSession& s = *session_;
  if (s.mouse != nullptr) {
    s.mouse->jump_to(s.model->tool_home);
    control_.reset(s.model->tool_home);
  }
  if (!s.run->restart()) return;
  have_snapshot_ = false;
  history_.clear();
  timing_ = TimingReport{};
  timing_refreshed_ = std::chrono::steady_clock::now();
}

void ViewerApp::handle_input() {
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.WantCaptureMouse) {
    // Camera: orbit with the middle button or alt + left; ctrl + wheel zooms.
    const double dx = io.MouseDelta.x, dy = io.MouseDelta.y;
    const bool orbit = io.MouseDown[2] || (io.KeyAlt && io.MouseDown[0]);
    const bool have_mouse = session_ && session_->mouse != nullptr;
    if (orbit && std::isfinite(dx) && std::isfinite(dy)) camera_.orbit(-0.01 * dx, 0.01 * dy);
    if (io.MouseWheel != 0.0f && (io.KeyCtrl || !have_mouse)) camera_.zoom(std::pow(0.9, io.MouseWheel));

    // The mouse device: left-drag moves the tool in the view plane, the wheel in depth, right-drag turns it.
    if (have_mouse) {
      if (!orbit && io.MouseDown[0] && std::isfinite(dx))
        control_.drag_move(dx, dy, camera_, io.DisplaySize.y);
      if (io.MouseDown[1] && std::isfinite(dx)) control_.drag_rotate(dx, dy, camera_);
      if (io.MouseWheel != 0.0f && !io.KeyCtrl) control_.wheel(io.MouseWheel, camera_, io.KeyShift);
      session_->mouse->set_target(control_.target());
    }
  }
  if (!io.WantCaptureKeyboard) {
    // Keys: R resets the tool, F frames the scene, L reveals or hides the lesions.
    if (ImGui::IsKeyPressed(GLFW_KEY_R, false) && session_ && session_->run->recorder() == nullptr)
      restart_servo();
    if (ImGui::IsKeyPressed(GLFW_KEY_F, false) && session_) camera_.frame(session_->view->bounds());
    // A trainee has no reveal key.
    if (ImGui::IsKeyPressed(GLFW_KEY_L, false) && !locked()) settings_.show_lesions = !settings_.show_lesions;
    // F1-F4 (and 1-4 outside a diagnosis case, where 1 and 2 choose the grade): the clinician's views
    // on the explorer's tip; T: the camera follows the tip.
    constexpr CameraPreset kKeys[] = {CameraPreset::Occlusal, CameraPreset::Buccal, CameraPreset::Lingual,
                                      CameraPreset::Operator};
    const bool grading = diagnosis_live();
    for (int k = 0; k < 4; ++k)
      if (ImGui::IsKeyPressed(GLFW_KEY_F1 + k, false) ||
          ((!grading || k >= 2) && ImGui::IsKeyPressed(GLFW_KEY_1 + k, false)))
        apply_preset(kKeys[k]);
    if (ImGui::IsKeyPressed(GLFW_KEY_T, false)) follow_tip_ = !follow_tip_;
    // In a diagnosis case: 1 mild, 2 severe (the next mark's grade); M marks at the tip.
    if (grading && ImGui::IsKeyPressed(GLFW_KEY_1, false)) grade_choice_ = 0;
    if (grading && ImGui::IsKeyPressed(GLFW_KEY_2, false)) grade_choice_ = 1;
    if (ImGui::IsKeyPressed(GLFW_KEY_M, false)) study_mark();
    // A debrief: Enter continues (or ends the last), as its button does.
    if (debrief_ && ImGui::IsKeyPressed(GLFW_KEY_ENTER, false)) debrief_go_on();
  }
}

ViewSettings ViewerApp::shown_settings() const {
  ViewSettings s = locked() ? trainee_settings(settings_) : settings_;
  // A debrief (the case has ended): its lesions and the recorded tool shown.
  if (debrief_) s.show_lesions = s.recorded_ghost = true;
  return s;
}

void ViewerApp::submit_passphrase(const std::string& passphrase) {
  // The check runs on the lock's worker thread (poll_lock collects it); a try within the back-off
  // after wrong passphrases is refused unchecked, and said so.
  switch (lock_.submit(passphrase)) {
    case InstructorLock::Submitted::Checking:
      lock_message_.clear();
      break;
    case InstructorLock::Submitted::Busy:
      break;
    case InstructorLock::Submitted::Wait:
      std::fprintf(stderr, "run: instructor passphrase not checked: next try in %.0f s (%d refused)\n",
                   std::ceil(lock_.wait_seconds()), lock_.refused());
      break;
    case InstructorLock::Submitted::NoHash:
      lock_message_ = "This window has no instructor passphrase (no course file).";
      std::fprintf(stderr, "run: wrong instructor passphrase (%d refused)\n", lock_.refused());
      break;
  }
}

void ViewerApp::poll_lock() {
  // A finished check: the full panel opens, or the refusal is counted and the next wait said.
  const std::optional<bool> outcome = lock_.poll();
  if (!outcome) return;
  if (*outcome) {
    lock_message_.clear();
    std::fprintf(stderr, "run: instructor unlocked the full panel\n");
    return;
  }
  const double wait = lock_.wait_seconds();
  lock_message_ = fmt::format("Wrong passphrase ({} refused).", lock_.refused());
  std::fprintf(stderr, "run: wrong instructor passphrase (%d refused%s)\n", lock_.refused(),
               wait > 0.0 ? fmt::format("; next try in {:.0f} s", std::ceil(wait)).c_str() : "");
}

void ViewerApp::run_script() {
  // Before the frame starts: release the key pressed in the last frame, then every step whose time
  // (servo time of the running session) has come, as the keyboard or the panel would do it.
  ImGuiIO& io = ImGui::GetIO();
  if (script_key_down_ >= 0) io.KeysDown[script_key_down_] = false;
  script_key_down_ = -1;
  // A step waits while a passphrase is being checked (as a user waits for the answer).
  while (script_next_ < script_.size() && have_snapshot_ && snapshot_.t >= script_[script_next_].t &&
         !lock_.checking()) {
    const ScriptStep& step = script_[script_next_];
    if (step.action == "key") {
      // One key a frame, so that each press is seen.
      if (script_key_down_ >= 0) break;
      script_key_down_ = script_key_code(step.argument);
      io.KeysDown[script_key_down_] = true;
    } else if (step.action == "passphrase") {
      submit_passphrase(step.argument);
    } else if (step.action == "lock") {
      lock_.lock();
    }
    ++script_next_;
  }
}

void ViewerApp::apply_preset(CameraPreset preset) {
  // On the explorer's tip once the servo has drawn it; until then the preset waits.
  if (!session_ || !have_snapshot_) {
    pending_preset_ = preset;
    return;
  }
  camera_.look(preset, snapshot_.out.graphic.p, session_->view->bounds().center(), 45.0, tool_sections());
  preset_ = preset;
  pending_preset_.reset();
}

std::vector<ToolSection> ViewerApp::tool_sections() const {
  // The tool's sections where the servo last drew the graphic tool.
  std::vector<ToolSection> world;
  if (!session_ || !have_snapshot_) return world;
  for (const ToolSection& s : session_->view->tool_sections())
    world.push_back({snapshot_.out.graphic.transform(s.center), s.radius});
  return world;
}

void ViewerApp::read_snapshot() {
  // A stopped session (a trial that ended, its next one building) publishes nothing new: its last
  // snapshot is not taken up again as the running session's.
  if (!session_ || !session_->run->running()) return;
  // The newest snapshot (lock-free); the plot keeps a few seconds of them.
  if (session_->run->latest(snapshot_)) {
    have_snapshot_ = true;
    history_.add(snapshot_.t, snapshot_.out.force, snapshot_.out.torque);
    if (pending_preset_) apply_preset(*pending_preset_);
    if (follow_tip_ && snapshot_.out.graphic.p.allFinite()) {
      camera_.target = snapshot_.out.graphic.p;
      // The occlusal view following the tip looks past the handle again when the hand turned it into
      // the line of sight (half the clearance: no back and forth at the edge).
      if (preset_ == CameraPreset::Occlusal &&
          camera_.tool_clearance(tool_sections()) < 0.5 * kOcclusalClearance)
        camera_.look(CameraPreset::Occlusal, snapshot_.out.graphic.p, session_->view->bounds().center(),
                     camera_.distance, tool_sections());
    }
  }
  // Timing and device counters about once a second.
  const auto now = std::chrono::steady_clock::now();
  if (now - timing_refreshed_ > std::chrono::seconds(1)) {
    timing_ = session_->run->loop().timing();
    counters_ = session_->run->device().counters();
    timing_refreshed_ = now;
  }
}

void ViewerApp::draw_scene(int width, int height) {
  // Clear to the background, then the scene for the latest snapshot.
  // The 3-D view takes the window left of the panel.
  const Rgba bg = background_color();
  glViewport(0, 0, width, height);
  glClearColor(bg[0], bg[1], bg[2], 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  view_width_ = std::max(1, width - static_cast<int>(kPanelWidth * ImGui::GetIO().DisplayFramebufferScale.x));
  if (!session_ || !have_snapshot_ || height <= 0) return;
  glViewport(0, 0, view_width_, height);
  FrameParams frame;
  frame.view = camera_.view();
  frame.projection = camera_.projection(static_cast<double>(view_width_) / height);
  frame.eye = camera_.eye();
  renderer_->begin(frame);
  std::optional<Pose> recorded;
  if (session_->replay != nullptr) recorded = session_->replay->recorded_graphic(snapshot_.t);
  session_->view->draw(*renderer_, snapshot_, shown_settings(), recorded);
  glViewport(0, 0, width, height);
}

int ViewerApp::run() {
  open_window();
  // A course starts its study once the participant is known (given, or typed in the panel).
  if (!options_.review.empty())
    start_review();
  else if (!course_)
    request_build(options_.scene);
  else if (!options_.participant.empty()) {
    // Given on the command line, a study that cannot start (its database) ends the run with the reason.
    start_study(options_.participant);
    if (!run_) throw Error(study_message_);
  }
  auto frame_start = std::chrono::steady_clock::now();
  while (glfwWindowShouldClose(window_) == GLFW_FALSE) {
    glfwPollEvents();
    poll_lock();
    run_script();
    poll_build();
    reap_builds();

    // One frame: input, the newest snapshot, the scene, the panel.
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    handle_input();
    read_snapshot();
    study_frame();
    debrief_frame();
    int width = 0, height = 0;
    glfwGetFramebufferSize(window_, &width, &height);
    draw_scene(width, height);
    draw_debrief_overlay(height);
    draw_panel();
    draw_build_progress();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());

    // Automation: once the servo clock passes exit_after, keep this frame and leave.
    // A course's study also ends the run once its last trial has ended.
    if (options_.exit_after > 0.0 &&
        ((have_snapshot_ && snapshot_.t >= options_.exit_after) ||
         (study_finished() && !build_ && (!debrief_ || debrief_replay_done()) && debrief_queue_.empty()))) {
      finish(width, height);
      break;
    }
    glfwSwapBuffers(window_);

    // Pace the display loop (there is no vsync under Xvfb) so the servo thread keeps a core.
    std::this_thread::sleep_until(frame_start + std::chrono::duration<double>(kFramePeriod));
    frame_start = std::chrono::steady_clock::now();
  }
  if (session_) session_->stop();
  if (session_) timing_ = session_->run->loop().timing();
  print_summary();
  return 0;
}

void ViewerApp::finish(int width, int height) {
  // Stop the loop (exact timing), then write the screenshot and its status file.
  if (session_) session_->stop();
  if (session_) timing_ = session_->run->loop().timing();
  if (options_.screenshot.empty()) return;
  write_png(read_framebuffer(width, height), options_.screenshot);
  const std::filesystem::path status = status_path(options_.screenshot);
  std::ofstream out(status, std::ios::trunc);
  out << status_json(width, height) << "\n";
  if (!out) throw Error(status.string() + ": cannot write the status file");
}

void ViewerApp::print_summary() const {
  // What the UI showed last, and the servo loop's timing (TimingReport).
  if (!session_) return;
  const StepOutput& out = snapshot_.out;
  // A trainee's run says nothing of the scene or the interaction (the terminal may be in view), also
  // after the instructor unlocked the panel.
  if (trainee_) {
    std::printf("run: trainee mode, device %s, %.0f Hz servo, t %.3f s\n", options_.device.c_str(),
                session_->run->rate_hz(), snapshot_.t);
  } else {
    std::printf("run: scene %s, device %s, %.0f Hz servo\n", session_->source.c_str(),
                options_.device.c_str(), session_->run->rate_hz());
    std::printf(
        "state %s, force %.3f N (rendered %.3f N), torque %.2f N*mm, depth %.3f mm, contacts %d, t %.3f s\n",
        state_name(out.state), out.force.norm(), snapshot_.force.norm(), out.torque.norm(), out.depth,
        out.contacts, snapshot_.t);
  }
  std::printf("servo: %llu cycles at %.1f Hz, %llu overruns, %llu steps cut short by the work budget; "
              "real-time: %s; polls the last %.0f us of each wait\n",
              static_cast<unsigned long long>(timing_.cycles), timing_.rate_hz,
              static_cast<unsigned long long>(timing_.overruns),
              static_cast<unsigned long long>(timing_.work_budget),
              session_->run->loop().realtime_status().c_str(), session_->run->loop().spin_us());
  std::printf("step time (us): p50 %.2f  p99 %.2f  p99.9 %.2f  max %.2f\n", timing_.step_p50,
              timing_.step_p99, timing_.step_p999, timing_.step_max);
  std::printf("jitter (us):    p50 %.2f  p99 %.2f  p99.9 %.2f  max %.2f\n", timing_.jitter_p50,
              timing_.jitter_p99, timing_.jitter_p999, timing_.jitter_max);
  if (!options_.screenshot.empty())
    std::printf("screenshot: %s (status: %s)\n", options_.screenshot.c_str(),
                status_path(options_.screenshot).string().c_str());
  std::fflush(stdout);
}

int run_viewer(const ViewerOptions& options) {
  ViewerApp app(options);
  return app.run();
}

}  // namespace cariesim::viewer
