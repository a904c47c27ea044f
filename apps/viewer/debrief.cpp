// The debrief screen (debrief.hpp): after a diagnosis case (the study file's `debrief:`) and for
// `cariesim review DB`. The case's session is replayed from its recording with the ghost tool on the
// case's model (the one the trainee probed, or rebuilt and checked against the recorded scene hash),
// the lesions revealed, the marks drawn on the teeth, the scores in words and the insertions listed.
#include "debrief.hpp"

#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "cariesim/common/error.hpp"
#include "cariesim/io/json.hpp"
#include "viewer_app.hpp"

namespace cariesim::viewer {

namespace {

// Colours of the marks and lesion labels (RGBA 0-255): found green, again blue, false red, in the
// air grey; lesions yellow.
ImU32 verdict_color(training::MarkVerdict v) {
  switch (v) {
    case training::MarkVerdict::Found:
      return IM_COL32(60, 220, 90, 255);
    case training::MarkVerdict::Again:
      return IM_COL32(90, 160, 255, 255);
    case training::MarkVerdict::False:
      return IM_COL32(240, 70, 60, 255);
    case training::MarkVerdict::InAir:
      return IM_COL32(170, 170, 170, 255);
  }
  return IM_COL32(240, 70, 60, 255);
}
constexpr ImU32 kLesionColor = IM_COL32(255, 210, 60, 255);

}  // namespace

std::string debrief_clock(double seconds) {
  const int s = static_cast<int>(std::lround(std::max(seconds, 0.0)));
  return fmt::format("{}:{:02d}", s / 60, s % 60);
}

std::string debrief_mark_line(const training::DebriefMark& m) {
  const std::string head =
      fmt::format("mark {} at {}, {}: ", m.number, debrief_clock(m.t), training::grade_name(m.grade));
  switch (m.verdict) {
    case training::MarkVerdict::Found:
      return head + fmt::format("found lesion {}", m.lesion);
    case training::MarkVerdict::Again:
      return head + fmt::format("lesion {} again (not counted)", m.lesion);
    case training::MarkVerdict::False:
      return head + fmt::format("false mark ({:.1f} mm from the nearest lesion)", m.distance);
    case training::MarkVerdict::InAir:
      return head + "made in the air (touching nothing)";
  }
  return head;
}

bool ViewerApp::open_case_debrief(const training::TrialResult& result, const Model* model) {
  // After a diagnosis case, when the study says so: the debrief now (the case's model and its
  // recording replayed), or queued for the study's end. Nothing of the case is shown before it ends.
  if (!study_ || !run_ || study_->kind != training::StudyKind::Diagnosis ||
      study_->debrief == training::DebriefWhen::Never)
    return false;
  DebriefScreen screen;
  try {
    const training::DiagnosisAnswers answers =
        training::parse_diagnosis_answers(result.answers_json, "the trial's answers");
    const std::filesystem::path recording = run_->recording_path();
    const Recording rec = load_recording(recording);
    screen.data = training::make_debrief(run_->setup(), answers, result.scores, &rec, study_->scoring);
    screen.recording = recording;
  } catch (const Error& e) {
    // No debrief rather than a stopped class: the reason may name the case, so only the instructor sees it.
    note_problem(fmt::format("trial {}: no debrief: {}", result.index + 1, e.what()));
    return false;
  }
  screen.title = fmt::format("Trial {} of {}", result.index + 1, run_->trial_count());
  screen.scene_yaml = run_->setup().scene_yaml;
  screen.scene_origin = run_->setup().scene_origin;
  if (study_->debrief == training::DebriefWhen::AtEnd) {
    debrief_queue_.push_back(std::move(screen));
    if (!run_->finished()) return false;
    show_next_debrief();
    return true;
  }
  // After each case: the model the trainee probed, replayed at once.
  const std::string source = session_ ? session_->source : std::string("debrief");
  std::unique_ptr<Model> owned =
      session_ && session_->model.get() == model ? std::move(session_->model) : nullptr;
  debrief_ = std::make_unique<DebriefScreen>(std::move(screen));
  if (owned) {
    next_device_ = "replay:" + debrief_->recording.string();
    start_session(std::move(owned), source, false);
  } else {
    debrief_queue_.insert(debrief_queue_.begin(), std::move(*debrief_));
    debrief_.reset();
    show_next_debrief();
  }
  return true;
}

void ViewerApp::show_next_debrief() {
  // The next queued debrief: its scene built again on the worker, then replayed (poll_build).
  if (debrief_queue_.empty()) return;
  debrief_ = std::make_unique<DebriefScreen>(std::move(debrief_queue_.front()));
  debrief_queue_.erase(debrief_queue_.begin());
  next_device_ = "replay:" + debrief_->recording.string();
  const std::string yaml = debrief_->scene_yaml, origin = debrief_->scene_origin;
  if (session_) session_->stop();
  request_build(
      fmt::format("debrief of {}", debrief_->title), [yaml, origin] { return parse_scene(yaml, origin); },
      false);
}

void ViewerApp::start_review() {
  // `cariesim review`: the trial rebuilt from the database alone, its recording, its debrief; the
  // scene is built on the worker and checked against the recorded hash before the replay.
  training::RebuiltTrial t =
      training::rebuild_trial(options_.review, options_.review_participant, options_.review_trial);
  if (t.study.kind != training::StudyKind::Diagnosis)
    throw Error(fmt::format("{}: {} is a {} trial: only a diagnosis case has a debrief", options_.review,
                            t.label(), training::study_kind_name(t.study.kind)));
  if (t.recording.empty())
    throw Error(fmt::format("{}: {} has no recording to replay", options_.review, t.label()));
  const Recording rec = load_recording(t.recording);
  auto screen = std::make_unique<DebriefScreen>();
  screen->data = training::make_debrief(t.setup, t.answers, t.scores, &rec, t.study.scoring);
  screen->title = t.label();
  screen->recording = t.recording;
  screen->review = true;
  screen->scene_yaml = t.setup.scene_yaml;
  screen->scene_origin = t.setup.scene_origin;
  screen->recorded = rec.info;
  screen->rebuilt = std::move(t);
  debrief_ = std::move(screen);
  settings_.show_lesions = true;
  next_device_ = "replay:" + debrief_->recording.string();
  std::fprintf(stderr, "review: %s of %s, study %s, recorded %s\n", debrief_->title.c_str(),
               options_.review.c_str(), debrief_->rebuilt->study_name.c_str(),
               debrief_->rebuilt->started_at.c_str());
  const std::string yaml = debrief_->scene_yaml, origin = debrief_->scene_origin;
  request_build(
      fmt::format("review of {}", debrief_->title), [yaml, origin] { return parse_scene(yaml, origin); },
      false);
}

void ViewerApp::check_debrief_scene(const Model& model) const {
  // A review's rebuilt scene must be the recorded one (throws naming both hashes).
  if (debrief_ && debrief_->rebuilt)
    training::check_rebuilt_scene(*debrief_->rebuilt, model, &debrief_->recorded);
}

bool ViewerApp::debrief_replay_done() const {
  // The replay has played the whole recording (its session is the debrief's).
  return debrief_ && !build_ && session_ && session_->replay != nullptr && have_snapshot_ &&
         session_->replay->finished(snapshot_.t);
}

void ViewerApp::continue_after_debrief() {
  // The next queued debrief, or the study's next trial.
  debrief_.reset();
  if (session_) session_->stop();
  if (!debrief_queue_.empty()) {
    show_next_debrief();
    return;
  }
  if (run_ && !run_->finished() && !run_->in_trial()) begin_trial();
}

void ViewerApp::debrief_frame() {
  // Automation (--answers): a debrief continues once its replay has played, except the study's last
  // (the window then ends on it, as a screenshot shows).
  if (!debrief_ || debrief_->review || !answers_ || !debrief_replay_done()) return;
  const bool last = run_ && run_->finished() && debrief_queue_.empty();
  if (!last) continue_after_debrief();
}

void ViewerApp::panel_debrief() {
  if (!debrief_) return;
  const training::Debrief& d = debrief_->data;
  ImGui::TextWrapped("%s: what was hidden, and what you did.", debrief_->title.c_str());
  if (session_ && session_->replay != nullptr && have_snapshot_)
    ImGui::Text("replay %s of %s", debrief_clock(snapshot_.t).c_str(),
                debrief_clock(session_->replay->duration()).c_str());
  ImGui::Separator();
  for (const std::string& line : d.lines) ImGui::TextWrapped("%s", line.c_str());
  // The marks with their colours on the teeth.
  if (!d.marks.empty()) {
    ImGui::Separator();
    for (const training::DebriefMark& m : d.marks) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImGui::ColorConvertU32ToFloat4(verdict_color(m.verdict)));
      ImGui::TextWrapped("%s", debrief_mark_line(m).c_str());
      ImGui::PopStyleColor();
    }
  }
  // The moments of insertion, those the replay has passed brighter.
  if (!d.insertions.empty()) {
    ImGui::Separator();
    for (const training::Insertion& in : d.insertions) {
      const bool passed = have_snapshot_ && snapshot_.t >= in.t;
      if (!passed) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(0.6f, 0.6f, 0.6f, 1.0f));
      ImGui::TextWrapped("%s into lesion %d, %.1f mm deep for %.1f s", debrief_clock(in.t).c_str(), in.lesion,
                         in.depth, in.duration);
      if (!passed) ImGui::PopStyleColor();
    }
  }
  ImGui::Separator();
  if (ImGui::Button("Replay again")) {
    const std::string source = session_ ? session_->source : std::string();
    std::unique_ptr<Model> model = session_ ? std::move(session_->model) : nullptr;
    if (model) {
      next_device_ = "replay:" + debrief_->recording.string();
      start_session(std::move(model), source, false);
    }
  }
  if (!debrief_->review) {
    ImGui::SameLine();
    if (ImGui::Button(debrief_has_more() ? "Continue (Enter)" : "Done (Enter)")) debrief_go_on();
  }
}

bool ViewerApp::debrief_has_more() const { return !debrief_queue_.empty() || (run_ && !run_->finished()); }

void ViewerApp::debrief_go_on() {
  // Continue (the next debrief or the next case) or Done (the last): the panel's button and Enter.
  if (!debrief_ || debrief_->review) return;
  if (debrief_has_more())
    continue_after_debrief();
  else
    debrief_.reset();
}

void ViewerApp::draw_debrief_overlay(int height) {
  // Over the 3-D view: each lesion's number at its centre, each mark as a ring with its number.
  if (!debrief_ || !session_ || !session_->model) return;
  ImDrawList* draw = ImGui::GetBackgroundDrawList();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  const auto at = [&](const Vec3& world, ImVec2& out) {
    Eigen::Vector2d px;
    if (!camera_.project(world, view_width_, height, px) || px.x() < 0 || px.x() >= view_width_ ||
        px.y() < 0 || px.y() >= height)
      return false;
    out = ImVec2(static_cast<float>(px.x()) / scale.x, static_cast<float>(px.y()) / scale.y);
    return true;
  };
  const auto& lesions = session_->model->lesions;
  for (std::size_t i = 0; i < lesions.size() && i < debrief_->data.lesions.size(); ++i) {
    ImVec2 p;
    if (!at(lesions[i].shape.center, p)) continue;
    const training::DebriefLesion& l = debrief_->data.lesions[i];
    const std::string label =
        fmt::format("L{} {}{}", l.number, training::grade_name(l.severity), l.found ? "" : " (missed)");
    draw->AddText(ImVec2(p.x + 8.0f, p.y - 22.0f), kLesionColor, label.c_str());
  }
  for (const training::DebriefMark& m : debrief_->data.marks) {
    ImVec2 p;
    if (!at(m.tip, p)) continue;
    draw->AddCircle(p, 7.0f, verdict_color(m.verdict), 16, 2.5f);
    draw->AddText(ImVec2(p.x + 8.0f, p.y + 2.0f), verdict_color(m.verdict), std::to_string(m.number).c_str());
  }
}

void ViewerApp::debrief_json(io::JsonWriter& json) const {
  // The debrief the window shows (null when none): counts a test can check.
  json.key("debrief");
  if (!debrief_) {
    json.null();
    return;
  }
  const training::Debrief& d = debrief_->data;
  json.begin_object();
  json.field("title", debrief_->title).field("review", debrief_->review);
  json.field("lesions", static_cast<int>(d.lesions.size()));
  json.field("found",
             static_cast<int>(std::count_if(d.lesions.begin(), d.lesions.end(),
                                            [](const training::DebriefLesion& l) { return l.found; })));
  json.field("marks", static_cast<int>(d.marks.size()));
  json.field("insertions", static_cast<int>(d.insertions.size()));
  json.field("replaying", session_ && session_->replay != nullptr);
  json.key("lines").begin_array();
  for (const std::string& line : d.lines) json.value(line);
  json.end_array();
  json.end_object();
}

}  // namespace cariesim::viewer
