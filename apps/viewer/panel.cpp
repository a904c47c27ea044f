// The viewer's ImGui panel (docs/viewer.md): scene picker, device and loop readouts, the force and
// torque plots, view toggles, the lesion sliders with presets and saving; and the status file of a
// screenshot.
#include <fmt/format.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>

#include "cariesim/common/error.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/io/json.hpp"
#include "viewer_app.hpp"

namespace cariesim::viewer {

namespace {

// The state's colour in the readout.
ImVec4 state_color(InteractionState state) {
  switch (state) {
    case InteractionState::Free:
      return {0.70f, 0.70f, 0.70f, 1.0f};
    case InteractionState::Sliding:
      return {0.40f, 0.90f, 0.40f, 1.0f};
    case InteractionState::Inserting:
      return {1.00f, 0.60f, 0.20f, 1.0f};
    case InteractionState::Extracting:
      return {1.00f, 0.90f, 0.30f, 1.0f};
  }
  return {1, 1, 1, 1};
}

// Names of the set bits of a flag word.
std::string flag_names(uint32_t flags, std::initializer_list<std::pair<uint32_t, const char*>> names) {
  std::string out;
  for (const auto& [bit, name] : names)
    if ((flags & bit) != 0) out += (out.empty() ? "" : ", ") + std::string(name);
  return out.empty() ? "-" : out;
}

// A double slider (logarithmic when asked); true when the user changed it.
bool slider(const char* label, double& value, double lo, double hi, const char* format, bool log = false) {
  return ImGui::SliderScalar(label, ImGuiDataType_Double, &value, &lo, &hi, format,
                             log ? ImGuiSliderFlags_Logarithmic : ImGuiSliderFlags_None);
}

// 0-255 integer channels of a colour.
void json_rgb(io::JsonWriter& json, const Rgba& c) {
  json.begin_array();
  for (int k = 0; k < 3; ++k)
    json.value(static_cast<int>(std::lround(std::clamp(c[k], 0.0f, 1.0f) * 255.0f)));
  json.end_array();
}

}  // namespace

void ViewerApp::draw_panel() {
  // The panel docks at the right edge, full height.
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - kPanelWidth, 0.0f), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, io.DisplaySize.y), ImGuiCond_Always);
  ImGui::Begin("cariesim", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  panel_.x = pos.x;
  panel_.y = pos.y;
  panel_.w = size.x;
  panel_.h = size.y;
  ImGui::PushItemWidth(-150.0f);
  sections_.clear();
  grade_box_ = {};
  if (debrief_ && section("Debrief")) panel_debrief();
  if (locked()) {
    // A trainee: the course and its study, the camera; the instructor's passphrase field.
    panel_trainee();
    if (course_ && section("Study")) panel_study();
    if (session_ && session_->haptic != nullptr && section("Device")) panel_device();
    if (session_ && section("View")) panel_camera();
    panel_instructor();
  } else {
    if (trainee_) panel_trainee();
    if (course_ && section("Study")) panel_study();
    // A course's scenes are its study's: no scene picker.
    if (!course_) panel_scene();
    if (session_) {
      if (session_->haptic != nullptr && section("Device")) panel_device();
      panel_status();
      panel_plots();
      panel_view();
      panel_lesion();
    }
    if (trainee_) panel_instructor();
  }
  ImGui::PopItemWidth();
  if (!panel_.message.empty()) {
    ImGui::Separator();
    if (panel_.message_is_error) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.4f, 0.4f, 1.0f));
    ImGui::TextWrapped("%s", panel_.message.c_str());
    if (panel_.message_is_error) ImGui::PopStyleColor();
  }
  // How far the panel scrolls when its content is taller than the window (px), and how far its widest
  // line reaches past the panel's right edge (px; 0: nothing is clipped).
  panel_.scroll_max = ImGui::GetScrollMaxY();
  panel_.overflow_x = ImGui::GetScrollMaxX();
  ImGui::End();
}

void ViewerApp::draw_build_progress() {
  if (!build_) return;
  // A small centred window with the build's stage and progress.
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(0.5f * (io.DisplaySize.x - kPanelWidth), 0.5f * io.DisplaySize.y),
                          ImGuiCond_Always, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSize(ImVec2(420.0f, 0.0f), ImGuiCond_Always);
  ImGui::Begin("Building", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                   ImGuiWindowFlags_NoSavedSettings);
  std::string stage;
  {
    const std::lock_guard lock(build_->mutex);
    stage = build_->stage;
  }
  // A trainee is not told which scene comes (its name may say where the lesions are).
  if (locked())
    ImGui::Text("Preparing the scene");
  else
    ImGui::Text("Building %s", build_->source.c_str());
  // A trainee sees no stage names (they name the lesion parts).
  ImGui::ProgressBar(static_cast<float>(build_->fraction.load()), ImVec2(-1.0f, 0.0f),
                     locked() ? nullptr : stage.c_str());
  if (session_) wrapped(disabled_color(), "The current scene keeps running until the new one is ready.");
  ImGui::End();
}

void ViewerApp::panel_scene() {
  if (!section("Scene")) return;
  ImGui::Text("%s", session_ ? session_->source.c_str() : "(building)");
  // Built-in scenes, and scene files by path; both rebuild the model on a worker thread.
  const std::vector<std::string> names = builtin_scene_names();
  panel_.builtin = std::clamp(panel_.builtin, 0, static_cast<int>(names.size()) - 1);
  if (ImGui::BeginCombo("built-in", names[panel_.builtin].c_str())) {
    for (int i = 0; i < static_cast<int>(names.size()); ++i)
      if (ImGui::Selectable(names[i].c_str(), i == panel_.builtin)) panel_.builtin = i;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  ImGui::BeginDisabled(build_ != nullptr);
  if (ImGui::Button("Load##builtin")) request_build(names[panel_.builtin]);
  ImGui::EndDisabled();
  ImGui::InputTextWithHint("file", "path/to/scene.yaml", &panel_.scene_path);
  ImGui::SameLine();
  ImGui::BeginDisabled(build_ != nullptr || panel_.scene_path.empty());
  if (ImGui::Button("Load##file")) request_build(panel_.scene_path);
  ImGui::EndDisabled();
  if (!build_error_.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.4f, 0.4f, 1.0f));
    ImGui::TextWrapped("%s", build_error_.c_str());
    ImGui::PopStyleColor();
  }
}

void ViewerApp::panel_device() {
  // A hardware device: what it is, its calibration (and what the operator must do), whether its
  // force is on, the clutch, the loop's rate, what it cannot render. Nothing here depends on the case.
  const HapticStatus st = session_->haptic->status();
  const ImVec4 warn(1.0f, 0.7f, 0.3f, 1.0f);
  ImGui::TextWrapped("%s %s", st.hardware.model.c_str(), st.hardware.serial.c_str());
  if (st.calibration.readiness == Readiness::Ready)
    ImGui::Text("calibrated");
  else
    wrapped(warn, "calibration: " + st.calibration.message);
  ImGui::Text("force %s   rate %.0f Hz", st.force_enabled ? "on" : "off (waiting)", snapshot_.rate_hz);
  if (st.clutched) wrapped(warn, "CLUTCH held: the tool stays, move your hand");
  if ((st.faults & kHardwareLost) != 0)
    wrapped(warn, "device lost: no force; it reconnects when the device answers again");
  else if (st.faults != 0)
    wrapped(warn, "device: " + describe_hardware_faults(st.faults));
  ImGui::TextWrapped("%s", st.rendering().c_str());
}

void ViewerApp::panel_status() {
  if (!section("Status")) return;
  const StepOutput& out = snapshot_.out;
  SceneSession& s = *session_;
  const DeviceInfo& device = s.run->device_info();
  // Device, and the limits in force (the scene's within what the device announced).
  ImGui::Text("device: %s", device.name.c_str());
  if (!device.description.empty()) ImGui::TextWrapped("  %s", device.description.c_str());
  const DeviceLimits& limits = s.run->params().limits;
  ImGui::Text("limits %.1f N  %.3f N/mm  %.0f N*mm", limits.max_force, limits.max_stiffness,
              limits.max_torque);
  // The interaction and the wrench.
  ImGui::Text("state:");
  ImGui::SameLine();
  ImGui::TextColored(state_color(out.state), "%s", have_snapshot_ ? state_name(out.state) : "(starting)");
  ImGui::Text("force %.3f N   torque %.2f N*mm", out.force.norm(), out.torque.norm());
  if (device.renders_force)
    ImGui::Text("rendered %.3f N (after force safety)", snapshot_.force.norm());
  else
    wrapped(disabled_color(), "renders no force: see the arrow and the plot");
  ImGui::Text("insertion depth %.3f mm   contacts %d", out.depth, out.contacts);
  ImGui::Text("soft tissue %.3f N", out.soft_tissue_force);
  if (settings_.show_lesions && out.lesion >= 0 &&
      static_cast<std::size_t>(out.lesion) < s.model->lesions.size())
    ImGui::Text("lesion: %s", s.model->lesions[out.lesion].name.c_str());
  ImGui::Text("step flags: %s", flag_names(out.flags, {{kFlagNonFiniteInput, "non-finite input"},
                                                       {kFlagJumpLimited, "jump"},
                                                       {kFlagInfeasible, "infeasible"},
                                                       {kFlagContactOverflow, "contact overflow"},
                                                       {kFlagForceClamped, "force clamped"},
                                                       {kFlagTorqueClamped, "torque clamped"},
                                                       {kFlagLagging, "lagging"},
                                                       {kFlagBacktracked, "backtracked"},
                                                       {kFlagCatchingUp, "catching up (no force)"}})
                                    .c_str());
  ImGui::Text("safety: %s", flag_names(snapshot_.safety_flags, {{kSafetyRamping, "ramping in"},
                                                                {kSafetyStale, "stale input"},
                                                                {kSafetyNonFinite, "non-finite"},
                                                                {kSafetyInvalidInput, "no input"},
                                                                {kSafetyJump, "jump"},
                                                                {kSafetyStopped, "stopped"}})
                                .c_str());
  // The servo loop.
  ImGui::Separator();
  ImGui::Text("servo %.0f Hz (set %.0f)   t %.1f s", snapshot_.rate_hz, s.run->rate_hz(), snapshot_.t);
  ImGui::Text("cycles %llu   overruns %llu   work budget %llu", static_cast<unsigned long long>(snapshot_.cycle),
              static_cast<unsigned long long>(snapshot_.overruns),
              static_cast<unsigned long long>(snapshot_.work_budget));
  ImGui::Text("step  p50 %.1f  p99 %.1f  max %.1f us", timing_.step_p50, timing_.step_p99, timing_.step_max);
  ImGui::Text("jitter p50 %.1f  p99 %.1f  max %.1f us", timing_.jitter_p50, timing_.jitter_p99,
              timing_.jitter_max);
  ImGui::TextWrapped("priority: %s; polls the last %.0f us", s.run->loop().realtime_status().c_str(),
                     s.run->loop().spin_us());
  if (const Recorder* recorder = s.run->recorder()) {
    const RecorderStatus record = recorder->status();
    ImGui::Text("recording %s (%llu samples)", options_.record.c_str(),
                static_cast<unsigned long long>(record.written));
    if (!record.ok) wrapped(ImVec4(1.0f, 0.4f, 0.4f, 1.0f), record.message);
  }
  // Device counters (the UDP bridge's packets).
  for (const DeviceCounter& c : counters_)
    ImGui::Text("  %s: %llu", c.name, static_cast<unsigned long long>(c.value));
  // Tool reset and the global force scale.
  ImGui::BeginDisabled(s.run->recorder() != nullptr);
  if (ImGui::Button("Reset tool (R)")) restart_servo();
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::SliderFloat("force scale", &panel_.force_scale, 0.0f, 1.0f, "%.2f"))
    post(ParamChange{ParamChange::Field::ForceScale, -1, static_cast<double>(panel_.force_scale)});
}

void ViewerApp::panel_plots() {
  if (!section("Force and torque")) return;
  // The last seconds of snapshots on a uniform grid.
  constexpr int kPoints = 240;
  const auto plot = [&](ForceHistory::Series series, const char* label, const char* unit, bool symmetric,
                        float height) {
    history_.resample(series, kPoints, plot_scratch_);
    const float peak = std::max(history_.max_in_window(series), 0.0f);
    float range = 1.0f;
    for (const float v : plot_scratch_) range = std::max(range, std::abs(v) * 1.1f);
    if (!symmetric) range = std::max(range, peak * 1.1f);
    const std::string overlay =
        fmt::format("{} {:.3f} {}", label, plot_scratch_.empty() ? 0.0f : plot_scratch_.back(), unit);
    ImGui::PlotLines(fmt::format("##{}", label).c_str(), plot_scratch_.data(),
                     static_cast<int>(plot_scratch_.size()), 0, overlay.c_str(), symmetric ? -range : 0.0f,
                     range, ImVec2(ImGui::GetContentRegionAvail().x, height));
  };
  ImGui::Text("last %.0f s", history_.window());
  plot(ForceHistory::Series::ForceNorm, "|F|", "N", false, 70.0f);
  plot(ForceHistory::Series::Fx, "Fx", "N", true, 36.0f);
  plot(ForceHistory::Series::Fy, "Fy", "N", true, 36.0f);
  plot(ForceHistory::Series::Fz, "Fz", "N", true, 36.0f);
  plot(ForceHistory::Series::TorqueNorm, "|T|", "N*mm", false, 50.0f);
}

void ViewerApp::panel_view() {
  if (!section("View")) return;
  ImGui::Checkbox("reveal lesions (L)", &settings_.show_lesions);
  ImGui::SameLine();
  ImGui::Checkbox("haptic ghost", &settings_.haptic_ghost);
  ImGui::Checkbox("contacts", &settings_.contacts);
  ImGui::SameLine();
  ImGui::Checkbox("tunnel", &settings_.tunnel);
  ImGui::SameLine();
  ImGui::Checkbox("force arrow", &settings_.force_arrow);
  ImGui::Checkbox("soft tissue dents", &settings_.dents);
  if (session_->replay != nullptr) {
    ImGui::SameLine();
    ImGui::Checkbox("recorded tool", &settings_.recorded_ghost);
  }
  // Sphere trees: a level and which object.
  ImGui::Checkbox("sphere trees", &settings_.trees);
  if (settings_.trees) {
    ImGui::SliderInt("level", &settings_.tree_level, 0, std::max(session_->view->max_tree_level(), 0));
    const auto& objects = session_->model->objects;
    const auto name_of = [&](int i) -> std::string {
      if (i == -1) return "every object and the tool";
      if (i == -2) return "the tool";
      return objects[i].name;
    };
    if (ImGui::BeginCombo("tree of", name_of(settings_.tree_object).c_str())) {
      for (int i = -2; i < static_cast<int>(objects.size()); ++i)
        if (ImGui::Selectable(name_of(i).c_str(), i == settings_.tree_object)) settings_.tree_object = i;
      ImGui::EndCombo();
    }
  }
  panel_camera();
}

void ViewerApp::panel_camera() {
  if (ImGui::Button("Frame scene (F)")) {
    camera_.frame(session_->view->bounds());
    preset_.reset();
  }
  // The clinician's views on the explorer's tip (keys F1-F4), and a camera that follows the tip (T).
  // The buttons flow onto a second line when the panel is too narrow for one.
  ImGui::Text("view on the tip (F1-F4):");
  constexpr CameraPreset kPresets[] = {CameraPreset::Occlusal, CameraPreset::Buccal, CameraPreset::Lingual,
                                       CameraPreset::Operator};
  for (int k = 0; k < 4; ++k) {
    const std::string label = std::to_string(k + 1) + " " + preset_name(kPresets[k]);
    same_line_if_fits(label.c_str());
    if (ImGui::Button(label.c_str())) apply_preset(kPresets[k]);
  }
  ImGui::Checkbox("follow the tip (T)", &follow_tip_);
  if (!locked()) {
    same_line_if_fits("tip over everything", ImGui::GetFrameHeight() + ImGui::GetStyle().ItemInnerSpacing.x);
    ImGui::Checkbox("tip over everything", &settings_.tip_xray);
  }
  wrapped(disabled_color(),
          "left-drag move, wheel depth (shift: fine), right-drag turn; middle- or alt-drag orbit, "
          "ctrl+wheel zoom");
}

void wrapped(const ImVec4& color, const std::string& text) {
  // Wrapped at the panel's edge, in a colour.
  ImGui::PushStyleColor(ImGuiCol_Text, color);
  ImGui::TextWrapped("%s", text.c_str());
  ImGui::PopStyleColor();
}

ImVec4 disabled_color() { return ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled); }

void same_line_if_fits(const char* label, float extra) {
  // The item's width: its label and frame padding (a button's), plus `extra` (a checkbox's box).
  const ImGuiStyle& style = ImGui::GetStyle();
  const float width = ImGui::CalcTextSize(label, nullptr, true).x + 2.0f * style.FramePadding.x + extra;
  const float last = ImGui::GetItemRectMax().x;
  const float right = ImGui::GetWindowPos().x + ImGui::GetWindowContentRegionMax().x;
  if (last + style.ItemSpacing.x + width <= right) ImGui::SameLine();
}

bool ViewerApp::section(const char* name) {
  sections_.emplace_back(name);
  return ImGui::CollapsingHeader(name, ImGuiTreeNodeFlags_DefaultOpen);
}

void ViewerApp::panel_trainee() {
  if (!section("Trainee")) return;
  // The course and this station; without a course, free practice.
  if (course_) {
    ImGui::TextWrapped("%s", course_->name.c_str());
    ImGui::Text("station %s", course_->station.c_str());
  } else {
    ImGui::TextWrapped("Trainee mode: explore the scene with the explorer.");
  }
}

void ViewerApp::panel_instructor() {
  if (!section("Instructor")) return;
  // Unlocked: a button locks again. Locked: the passphrase field (hidden characters).
  if (lock_.unlocked()) {
    ImGui::TextWrapped("The full panel is open: lesions, states and overlays are visible.");
    if (ImGui::Button("Lock (back to trainee mode)")) lock_.lock();
    // What went wrong with a trial, in full (the trainee saw only "call the instructor").
    if (!problem_detail_.empty()) ImGui::TextWrapped("Last trial problem: %s", problem_detail_.c_str());
    return;
  }
  if (!lock_.can_unlock()) {
    wrapped(disabled_color(), "No instructor passphrase: run with --course to allow unlocking.");
    return;
  }
  // While a passphrase is checked (on the lock's worker) or the back-off runs, no new try.
  const double wait = lock_.wait_seconds();
  const bool busy = lock_.checking() || wait > 0.0;
  ImGui::BeginDisabled(busy);
  const bool enter = ImGui::InputText("passphrase", &passphrase_input_,
                                      ImGuiInputTextFlags_Password | ImGuiInputTextFlags_EnterReturnsTrue);
  ImGui::SameLine();
  if ((ImGui::Button("Unlock") || enter) && !passphrase_input_.empty() && !busy) {
    submit_passphrase(passphrase_input_);
    passphrase_input_.clear();
  }
  ImGui::EndDisabled();
  if (lock_.checking())
    ImGui::TextDisabled("Checking the passphrase...");
  else if (wait > 0.0)
    wrapped(
        ImVec4(1.0f, 0.4f, 0.4f, 1.0f),
        fmt::format("{} Too many wrong passphrases: next try in {:.0f} s.", lock_message_, std::ceil(wait)));
  else if (!lock_message_.empty())
    wrapped(ImVec4(1.0f, 0.4f, 0.4f, 1.0f), lock_message_);
}

void ViewerApp::panel_lesion() {
  if (!section("Lesion parameters")) return;
  SceneSession& s = *session_;
  if (s.model->lesions.empty()) {
    ImGui::TextDisabled("this scene has no lesions");
    return;
  }
  panel_.lesion = std::clamp(panel_.lesion, 0, static_cast<int>(s.model->lesions.size()) - 1);
  if (ImGui::BeginCombo("lesion", s.model->lesions[panel_.lesion].name.c_str())) {
    for (int i = 0; i < static_cast<int>(s.model->lesions.size()); ++i)
      if (ImGui::Selectable(s.model->lesions[i].name.c_str(), i == panel_.lesion)) panel_.lesion = i;
    ImGui::EndCombo();
  }
  // The sliders show the running Params as the servo thread published them; each change goes to it
  // as a ParamChange (a refused one leaves the slider where it was).
  const auto lesion = static_cast<int16_t>(panel_.lesion);
  const Material m = s.run->params().materials[s.model->lesions[panel_.lesion].material];
  using F = ParamChange::Field;
  const auto edit = [&](const char* label, F field, double value, double lo, double hi, const char* format,
                        bool log) {
    if (slider(label, value, lo, hi, format, log)) post(ParamChange{field, lesion, value});
  };
  edit("mu_s", F::MuS, m.mu_s, 0.0, 1.5, "%.3f", false);
  edit("mu_d", F::MuD, m.mu_d, 0.0, 1.5, "%.3f", false);
  edit("k_e (N/mm)", F::KE, m.k_e, 0.05, 5.0, "%.3f", true);
  edit(m.k_c.kind == KcProfile::Kind::Constant ? "k_c (N/mm)" : "k_c (N/mm, layered)", F::KC, m.k_c.at(0.0),
       0.05, 20.0, "%.3f", true);
  edit("F_p* (N)", F::FPStar, m.f_p_star, 0.1, 20.0, "%.2f", true);
  edit("F_e* (N)", F::FEStar, m.f_e_star, 0.1, 20.0, "%.2f", true);
  edit("stiffness (N/mm)", F::Stiffness, std::isfinite(m.stiffness) ? m.stiffness : 10.0, 0.05, 50.0, "%.3f",
       true);
  if (ImGui::Button("Mild preset")) post(ParamChange{F::Preset, lesion, 0.0});
  ImGui::SameLine();
  if (ImGui::Button("Severe preset")) post(ParamChange{F::Preset, lesion, 1.0});

  // Saving: a scene file in place (with a .bak), a built-in scene to a new file.
  ImGui::Separator();
  const bool builtin = !builtin_scene_yaml(s.source).empty();
  if (builtin) {
    if (panel_.save_path.empty()) panel_.save_path = s.source + "-tuned.yaml";
    ImGui::InputText("save as", &panel_.save_path);
    ImGui::BeginDisabled(panel_.save_path.empty());
    if (ImGui::Button("Save to a new scene file")) save_scene();
    ImGui::EndDisabled();
  } else if (ImGui::Button("Save to the scene file")) {
    save_scene();
  }
  wrapped(disabled_color(), "Saving rewrites the YAML: comments are not kept.");
}

void ViewerApp::post(const ParamChange& change) {
  if (!session_) return;
  // The servo thread applies it between two steps and publishes the Params the panel shows; a
  // recorded session notes it as a "param" event.
  if (!session_->run->post(change)) {
    panel_.message = "The parameter queue is full; try again.";
    panel_.message_is_error = true;
  }
}

void ViewerApp::save_scene() {
  SceneSession& s = *session_;
  // Every lesion's material as the servo thread runs it.
  const Params& running = s.run->params();
  std::vector<LesionMaterialEdit> edits;
  for (const LesionModel& lesion : s.model->lesions)
    edits.push_back({lesion.name, running.materials[lesion.material]});
  const bool builtin = !builtin_scene_yaml(s.source).empty();
  const std::filesystem::path target =
      builtin ? std::filesystem::path(panel_.save_path) : std::filesystem::path(s.source);
  try {
    const std::filesystem::path backup = save_lesion_materials(s.source, target, edits);
    panel_.message =
        fmt::format("Saved the lesion parameters to {}; comments are not kept{}.", target.string(),
                    backup.empty() ? "" : fmt::format(" (the previous file is {})", backup.string()));
    panel_.message_is_error = false;
  } catch (const Error& e) {
    panel_.message = e.what();
    panel_.message_is_error = true;
  }
}

std::string ViewerApp::status_json(int width, int height) const {
  // What the UI showed in the screenshot's frame, and where things are in the image (px, top-left).
  const StepOutput& out = snapshot_.out;
  io::JsonWriter json;
  json.begin_object();
  // The mode: a trainee's window (locked), the instructor's unlocked one, or the ordinary window.
  json.field("mode", locked() ? "trainee" : trainee_ ? "instructor" : "full");
  json.field("device", options_.device);
  if (session_ && session_->haptic != nullptr) {
    // A hardware device's state (nothing in it depends on the case).
    const HapticStatus st = session_->haptic->status();
    json.key("hardware").begin_object();
    json.field("model", st.hardware.model);
    json.field("calibrated", st.calibration.readiness == Readiness::Ready);
    json.field("calibration", st.calibration.message);
    json.field("force_enabled", st.force_enabled);
    json.field("force_was_enabled", st.force_was_enabled);
    json.field("clutch", st.clutched);
    json.field("faults", describe_hardware_faults(st.faults));
    json.field("rendering", st.rendering());
    json.field("torque_dropped_cycles", static_cast<long long>(st.torque_dropped));
    json.field("torque_dropped_max_nmm", st.torque_dropped_max);
    json.end_object();
  }
  json.field("t", snapshot_.t);
  json.key("panel_sections").begin_array();
  for (const std::string& name : sections_) json.value(name);
  json.end_array();
  study_json(json);
  debrief_json(json);
  if (trainee_) {
    json.key("instructor").begin_object();
    json.field("can_unlock", lock_.can_unlock());
    json.field("unlocked", lock_.unlocked());
    json.field("refused", lock_.refused());
    json.field("checking", lock_.checking());
    json.field("deferred", lock_.deferred());
    json.field("retry_in", lock_.wait_seconds());
    json.end_object();
  }
  // The scene and the engine's readouts: not in a trainee's file (they would name or locate lesions).
  if (!locked()) {
    json.field("scene", session_ ? session_->source : std::string());
    json.field("state", state_name(out.state));
    json.key("force")
        .begin_array()
        .value(out.force.x())
        .value(out.force.y())
        .value(out.force.z())
        .end_array();
    json.field("force_norm", out.force.norm());
    json.field("rendered_force_norm", snapshot_.force.norm());
    json.field("torque_norm", out.torque.norm());
    json.field("depth", out.depth);
    json.field("contacts", out.contacts);
    json.field("lesions_shown", settings_.show_lesions);
  }
  json.key("timing").begin_object();
  json.field("cycles", static_cast<long long>(timing_.cycles));
  json.field("overruns", static_cast<long long>(timing_.overruns));
  json.field("work_budget", static_cast<long long>(timing_.work_budget));
  json.field("standby_cycles", static_cast<long long>(timing_.standby_cycles));
  json.field("rate_hz", timing_.rate_hz);
  json.field("spin_us", session_ ? session_->run->loop().spin_us() : 0.0);
  json.field("step_p50_us", timing_.step_p50).field("step_p99_us", timing_.step_p99);
  json.field("step_p999_us", timing_.step_p999).field("step_max_us", timing_.step_max);
  json.field("jitter_p50_us", timing_.jitter_p50).field("jitter_p99_us", timing_.jitter_p99);
  json.field("jitter_p999_us", timing_.jitter_p999).field("jitter_max_us", timing_.jitter_max);
  json.end_object();
  json.field("width", width).field("height", height);
  json.key("background");
  json_rgb(json, background_color());
  json.key("tool_color");
  json_rgb(json, tool_color());
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  json.key("panel").begin_object();
  json.field("x", static_cast<double>(panel_.x * scale.x))
      .field("y", static_cast<double>(panel_.y * scale.y));
  json.field("w", static_cast<double>(panel_.w * scale.x))
      .field("h", static_cast<double>(panel_.h * scale.y));
  json.field("scroll_max", static_cast<double>(panel_.scroll_max * scale.y));
  json.field("overflow_x", static_cast<double>(panel_.overflow_x * scale.x));
  json.end_object();
  json.field("camera", preset_ ? preset_name(*preset_) : "framed");
  json.key("view")
      .begin_object()
      .field("x", 0)
      .field("y", 0)
      .field("w", view_width_)
      .field("h", height)
      .end_object();

  // The tool tip and points along the tool in the image, when in the view.
  const auto pixel = [&](const Vec3& world, Eigen::Vector2d& px) {
    return camera_.project(world, view_width_, height, px) && px.x() >= 0 && px.x() < view_width_ &&
           px.y() >= 0 && px.y() < height;
  };
  Eigen::Vector2d px;
  json.key("tip");
  if (pixel(out.graphic.p, px))
    json.begin_array().value(px.x()).value(px.y()).end_array();
  else
    json.null();
  // deg, how far the tool's handle stays from the line of sight to the tip (camera.hpp; negative: it
  // hides the tip), null without a tool in view.
  const double clearance = camera_.tool_clearance(tool_sections());
  json.key("tool_clearance_deg");
  if (std::isfinite(clearance))
    json.value(clearance * 180.0 / M_PI);
  else
    json.null();
  json.key("tool_points").begin_array();
  if (session_)
    for (const Vec3& local : session_->view->tool_axis_points())
      if (pixel(out.graphic.transform(local), px)) json.begin_array().value(px.x()).value(px.y()).end_array();
  json.end_array();

  // The object the strongest contact touches, and the colour it is drawn in (not for a trainee).
  if (locked()) {
    json.end_object();
    return json.str();
  }
  json.key("touched");
  const int count = std::clamp(out.contact_report_count, 0, kMaxReportedContacts);
  const ContactReport* strongest = nullptr;
  for (int i = 0; i < count; ++i)
    if (strongest == nullptr || out.contact_reports[i].force > strongest->force)
      strongest = &out.contact_reports[i];
  if (session_ && strongest != nullptr && strongest->object < session_->model->objects.size()) {
    const int object = strongest->object;
    json.begin_object();
    json.field("object", session_->model->objects[object].name);
    json.field("tissue", tissue_name(session_->view->object_display_tissue(object, shown_settings())));
    json.key("color");
    json_rgb(json, session_->view->object_color(object, shown_settings()));
    json.field("force", strongest->force);
    json.end_object();
  } else {
    json.null();
  }
  json.end_object();
  return json.str();
}

}  // namespace cariesim::viewer
