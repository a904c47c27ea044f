// The course's study in the viewer (docs/instructors.md): the participant, each trial's scene with
// its recorded session, what the trial asks (tuning sliders and Confirm, a shape per cube, diagnosis
// marks with a grade, End case, the countdown) and its end through the training API (StudyRun), which
// scores it and writes the study database. An answers file (--answers) can play the participant
// through the same calls the panel makes.
#include <fmt/format.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cariesim/common/error.hpp"
#include "cariesim/io/json.hpp"
#include "viewer_app.hpp"

namespace cariesim::viewer {

namespace {

// The ParamChange field a tuned parameter moves (names of study_schema.hpp's kScore*).
bool tuned_field(const std::string& name, ParamChange::Field& out) {
  using F = ParamChange::Field;
  if (name == "mu_s")
    out = F::MuS;
  else if (name == "mu_d")
    out = F::MuD;
  else if (name == "k_c")
    out = F::KC;
  else if (name == "k_e")
    out = F::KE;
  else
    return false;
  return true;
}

// "m:ss".
std::string clock_text(double seconds) {
  const int s = static_cast<int>(std::ceil(std::max(seconds, 0.0)));
  return fmt::format("{}:{:02d}", s / 60, s % 60);
}

}  // namespace

void ViewerApp::note_problem(const std::string& detail) {
  // In trainee mode the terminal may be in the trainee's view: it gets no detail, the instructor's
  // panel keeps it (and the study database has it where the trial's row exists).
  problem_detail_ = detail;
  if (trainee_)
    std::fprintf(stderr, "run: a trial problem (the instructor's panel shows it)\n");
  else
    std::fprintf(stderr, "run: %s\n", detail.c_str());
}

bool ViewerApp::trial_live() const {
  return run_ && run_->in_trial() && !build_ && session_ && session_->run->running();
}

bool ViewerApp::diagnosis_live() const {
  return trial_live() && run_->setup().kind == training::StudyKind::Diagnosis && !run_->answers().ended_at;
}

void ViewerApp::start_study(const std::string& participant) {
  // The run for this participant on this station's database (created with its folder), then the
  // first trial.
  if (!course_ || !study_ || run_) return;
  if (!course_->allows(participant)) {
    study_message_ = course_->participants.empty()
                         ? "Not a valid ID: letters, digits, '.', '_' or '-'."
                         : fmt::format("'{}' is not on this course's list of participants.", participant);
    study_message_is_error_ = true;
    return;
  }
  training::RunOptions run_options;
  run_options.participant = participant;
  run_options.station = course_->station;
  run_options.database = course_->database();
  run_options.trials = options_.trials;
  // A course's exam seed gives every trainee the same cases (--seed still sets the seed).
  training::apply_course_seed(*course_, run_options);
  if (options_.seed) run_options.seed = options_.seed;
  run_options.overrides = options_.overrides;
  // Nothing on disk names the running trial's case (its seed waits for its end; its recording is
  // held in memory, start_session); a new records folder is owner-only.
  run_options.hide_case_while_running = true;
  try {
    training::create_study_folder(course_->records);
  } catch (const Error& e) {
    study_message_ = std::string("cannot create the records folder: ") + e.what();
    study_message_is_error_ = true;
    std::fprintf(stderr, "run: %s\n", study_message_.c_str());
    return;
  }
  // A database that cannot be opened or written is said in the panel (and on stderr); the window stays.
  try {
    run_ = std::make_unique<training::StudyRun>(*study_, run_options);
  } catch (const Error& e) {
    study_message_ = e.what();
    study_message_is_error_ = true;
    std::fprintf(stderr, "run: cannot start the study: %s\n", e.what());
    return;
  }
  // Not the seed: it rebuilds every case (each trial's seed is in the database once the trial ends).
  std::fprintf(stderr, "run: study %s for %s at station %s, %d trials, database %s\n", study_->name.c_str(),
               participant.c_str(), course_->station.c_str(), run_->trial_count(),
               course_->database().string().c_str());
  study_message_.clear();
  begin_trial();
}

void ViewerApp::begin_trial() {
  // The run's next trial (its row is committed, ended_at NULL), then its scene on the worker thread;
  // the trial's session starts, recording, when the scene is ready (poll_build).
  have_snapshot_ = false;
  training::TrialSetup copy;
  try {
    copy = run_->begin_trial();
  } catch (const Error& e) {
    // The database refused the row (or the trial cannot be made). The reason may name the case: the
    // trainee (and the terminal) are told to call the instructor, who sees it in the unlocked panel.
    study_message_ = locked() ? std::string("The next trial could not begin; please call the instructor.")
                              : std::string("The next trial could not begin: ") + e.what();
    study_message_is_error_ = true;
    note_problem(fmt::format("the next trial could not begin: {}", e.what()));
    return;
  }
  const training::TrialSetup& setup = copy;
  const std::string label = fmt::format("trial {} of {}", setup.index + 1, run_->trial_count());
  // The scene built ahead while the last trial ran, when it is this trial's; else built now.
  if (next_build_ && next_build_->key == setup.scene_origin + "\n" + setup.scene_yaml) {
    build_error_.clear();
    build_ = std::move(next_build_);
    std::fprintf(stderr, "run: %s was built in the background\n", label.c_str());
    return;
  }
  if (next_build_) stale_builds_.push_back(std::move(next_build_));
  request_build(
      label, [copy] { return copy.scene(); }, true);
}

void ViewerApp::end_trial() {
  // Stop the session (the recording is complete on disk), then score the trial and write its row.
  if (!run_ || !run_->in_trial()) return;
  const int index = run_->current_trial();
  if (session_) session_->stop();
  have_snapshot_ = false;
  try {
    training::TrialResult result =
        run_->end_trial(run_->recording_path(), session_ ? session_->model.get() : nullptr);
    std::fprintf(stderr, "run: trial %d of %d ended (row %lld)\n", index + 1, run_->trial_count(),
                 static_cast<long long>(result.row));
    results_.push_back(std::move(result));
    study_message_.clear();
    // The case's debrief, when the study asks for one (debrief.cpp); the next trial waits for it.
    if (open_case_debrief(results_.back(), session_ ? session_->model.get() : nullptr)) return;
  } catch (const Error& e) {
    // The row keeps ended_at NULL, with the reason (it may name the case's lesions); the run moves on.
    study_message_ = locked()
                         ? fmt::format("Trial {} could not be saved; please call the instructor.", index + 1)
                         : fmt::format("Trial {} could not be saved: {}", index + 1, e.what());
    study_message_is_error_ = true;
    note_problem(fmt::format("trial {} could not be saved: {}", index + 1, e.what()));
    run_->abandon_trial(e.what());
  }
  if (!run_->finished()) begin_trial();
}

void ViewerApp::reset_tuning_sliders() {
  // Each slider at this trial's drawn start, sent to the servo thread as the panel's sliders do.
  tuning_values_.clear();
  if (!run_) return;
  for (const training::TunedParameter& p : run_->setup().parameters) {
    tuning_values_[p.name] = p.start;
    ParamChange::Field field{};
    if (tuned_lesion_ >= 0 && tuned_field(p.name, field))
      post(ParamChange{field, static_cast<int16_t>(tuned_lesion_), p.start});
  }
}

void ViewerApp::confirm_tuning() {
  // The current level's values; after the last level the trial ends.
  if (!trial_live() || !run_->current_level()) return;
  try {
    run_->confirm_tuning(tuning_values_, snapshot_.t);
  } catch (const Error& e) {
    study_message_ = e.what();
    study_message_is_error_ = true;
    return;
  }
  if (run_->current_level())
    reset_tuning_sliders();
  else
    end_trial();
}

void ViewerApp::submit_shapes() {
  // A shape for every cube, then the trial ends.
  if (!trial_live()) return;
  const training::TrialSetup& setup = run_->setup();
  try {
    for (std::size_t cube = 0; cube < shape_choice_.size(); ++cube) {
      if (shape_choice_[cube] < 0) throw Error(fmt::format("name the shape of cube {} first", cube + 1));
      run_->name_shape(static_cast<int>(cube),
                       setup.shape_choices.at(static_cast<std::size_t>(shape_choice_[cube])));
    }
  } catch (const Error& e) {
    study_message_ = e.what();
    study_message_is_error_ = true;
    return;
  }
  end_trial();
}

void ViewerApp::study_mark(std::optional<training::Grade> graded) {
  // A diagnosis mark at the graphic tool's tip (the tool frame's origin), with the given grade (a
  // device's mark button) or the chosen one, and whether the tool touched anything then (a mark in
  // the air detects nothing).
  if (!trial_live() || !have_snapshot_ || run_->setup().kind != training::StudyKind::Diagnosis) return;
  if (run_->answers().ended_at) return;
  const training::Grade grade =
      graded.value_or(grade_choice_ == 0 ? training::Grade::Mild : training::Grade::Severe);
  try {
    run_->mark(snapshot_.out.graphic.p, grade, snapshot_.t, snapshot_.out.contacts > 0);
  } catch (const Error& e) {
    study_message_ = e.what();
    study_message_is_error_ = true;
  }
}

void ViewerApp::study_frame() {
  if (!trial_live() || !have_snapshot_) return;
  const training::TrialSetup& setup = run_->setup();
  // A device's buttons, on their rising edge: a hardware device's profile maps them to actions (mark
  // mild, mark severe, end case; the clutch is the device's own); a device without a map (the UDP
  // bridge, a recording) marks with the chosen grade on any button.
  const uint32_t buttons = snapshot_.device.buttons;
  const uint32_t actions = snapshot_.device.actions;
  const uint32_t pressed = actions & ~previous_actions_;
  previous_actions_ = actions;
  const bool any_button = (buttons & ~previous_buttons_) != 0;
  previous_buttons_ = buttons;
  if ((pressed & kActionMarkMild) != 0) study_mark(training::Grade::Mild);
  if ((pressed & kActionMarkSevere) != 0) study_mark(training::Grade::Severe);
  if (session_->haptic == nullptr && any_button) study_mark();
  if ((pressed & kActionEndCase) != 0 && setup.kind == training::StudyKind::Diagnosis &&
      !run_->answers().ended_at) {
    run_->end_case(snapshot_.t);
    end_trial();
    return;
  }
  if (snapshot_.device.valid) device_seen_valid_ = true;
  // The answers file plays the participant.
  if (answers_ && !answers_->trials.empty()) {
    play_answers();
    if (!trial_live()) return;
  }
  // A diagnosis case ends at its time limit (without End case).
  if (setup.kind == training::StudyKind::Diagnosis && setup.time_limit > 0.0 &&
      snapshot_.t >= setup.time_limit)
    end_trial();
}

void ViewerApp::play_answers() {
  // This trial's entry (the last repeats): marks at their times (at the recorded tip unless the entry
  // gives a point), and at the entry's `end` or when the scripted path ends: the tuned values, the
  // shapes, or End case, through the calls the panel's buttons make.
  const auto& entries = answers_->trials;
  const training::ScriptedTrial& entry =
      entries[std::min<std::size_t>(run_->current_trial(), entries.size() - 1)];
  const training::TrialSetup& setup = run_->setup();
  const double t = snapshot_.t;
  // The marks whose servo time has come, each at that time with the tip the servo thread took then
  // (SceneSession::capture), as `cariesim study run` takes it from the recording; a mark after the
  // entry's end or the time limit is not made.
  const TimedCapture* capture = session_->capture.get();
  const std::size_t taken = capture != nullptr ? std::min(capture->taken(), answer_order_.size()) : 0;
  while (answer_mark_next_ < taken) {
    const training::ScriptedMark& m = entry.marks[answer_order_[answer_mark_next_]];
    const TimedCapture::Entry& tip = capture->entry(answer_mark_next_++);
    if ((setup.time_limit > 0.0 && m.t > setup.time_limit) || (entry.end && m.t > *entry.end)) continue;
    try {
      // An explicit point counts as touched (as `cariesim study run` takes it); else the tip's contact.
      if (m.at)
        run_->mark(*m.at, m.grade, m.t, m.contact);
      else
        run_->mark(tip.graphic.p, m.grade, m.t, tip.contacts > 0);
    } catch (const Error& e) {
      study_message_ = e.what();
      study_message_is_error_ = true;
    }
  }
  const bool path_ended = device_seen_valid_ && !snapshot_.device.valid;
  if (!(entry.end ? t >= *entry.end : path_ended)) return;
  switch (setup.kind) {
    case training::StudyKind::Tuning:
      // Each level's values, confirmed in the order asked; then the trial ends (a level the file
      // lacks leaves the trial unfinished).
      while (run_->current_level()) {
        const auto level = entry.tuning.find(std::string(training::grade_name(*run_->current_level())));
        if (level == entry.tuning.end()) {
          study_message_ = fmt::format("{}: no values for the {} level", answers_->origin,
                                       training::grade_name(*run_->current_level()));
          study_message_is_error_ = true;
          break;
        }
        for (const auto& [name, value] : level->second) {
          tuning_values_[name] = value;
          ParamChange::Field field{};
          if (tuned_lesion_ >= 0 && tuned_field(name, field))
            post(ParamChange{field, static_cast<int16_t>(tuned_lesion_), value});
        }
        try {
          run_->confirm_tuning(tuning_values_, t);
        } catch (const Error& e) {
          study_message_ = e.what();
          study_message_is_error_ = true;
          break;
        }
      }
      end_trial();
      break;
    case training::StudyKind::Boundary:
      for (std::size_t cube = 0; cube < shape_choice_.size(); ++cube) {
        const std::string name = cube < entry.shapes.size() ? entry.shapes[cube] : std::string();
        const auto it = std::find(setup.shape_choices.begin(), setup.shape_choices.end(), name);
        shape_choice_[cube] =
            it == setup.shape_choices.end() ? -1 : static_cast<int>(it - setup.shape_choices.begin());
      }
      submit_shapes();
      if (trial_live()) end_trial();  // an incomplete answer still ends the trial (its row stays open)
      break;
    case training::StudyKind::Diagnosis:
      // At the entry's end time (servo time), as `cariesim study run` ends it.
      run_->end_case(entry.end ? std::min(*entry.end, t) : t);
      end_trial();
      break;
  }
}

void ViewerApp::panel_study() {
  if (!course_ || !study_) return;
  // Before the run: the participant's ID.
  if (!run_) {
    ImGui::TextWrapped("Type your participant ID and press Start.");
    const bool enter =
        ImGui::InputText("participant", &participant_input_, ImGuiInputTextFlags_EnterReturnsTrue);
    ImGui::SameLine();
    if ((ImGui::Button("Start") || enter) && !participant_input_.empty()) start_study(participant_input_);
  } else {
    ImGui::Text("participant %s   study %s", run_->options().participant.c_str(), study_->name.c_str());
    if (run_->finished()) {
      ImGui::TextWrapped("The study is complete: %zu trials saved. Thank you.", results_.size());
    } else if (!trial_live()) {
      ImGui::Text("Trial %d of %d: preparing...", run_->current_trial() + 1, run_->trial_count());
    } else {
      const training::TrialSetup& setup = run_->setup();
      ImGui::Text("Trial %d of %d", run_->current_trial() + 1, run_->trial_count());
      ImGui::Separator();
      switch (setup.kind) {
        case training::StudyKind::Tuning: {
          // Sliders of the parameters to tune (live), and Confirm for the current level.
          const auto level = run_->current_level();
          if (!level) break;
          const std::size_t done = run_->answers().tuned.size();
          ImGui::TextWrapped(
              "Level %zu of %zu: move the sliders until the lesion feels like %s caries, then "
              "Confirm.",
              done + 1, setup.levels.size(), std::string(training::grade_name(*level)).c_str());
          for (const training::TunedParameter& p : setup.parameters) {
            double& value = tuning_values_[p.name];
            const std::string label = p.unit.empty() ? p.name : fmt::format("{} ({})", p.name, p.unit);
            if (ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &value, &p.min, &p.max, "%.3f")) {
              ParamChange::Field field{};
              if (tuned_lesion_ >= 0 && tuned_field(p.name, field))
                post(ParamChange{field, static_cast<int16_t>(tuned_lesion_), value});
            }
          }
          if (ImGui::Button(fmt::format("Confirm {}", training::grade_name(*level)).c_str()))
            confirm_tuning();
          break;
        }
        case training::StudyKind::Boundary: {
          // A shape per cube, left to right.
          ImGui::TextWrapped("Slide the explorer over each cube's top and name the shape hidden in it.");
          for (std::size_t cube = 0; cube < shape_choice_.size(); ++cube) {
            ImGui::Text("cube %zu:", cube + 1);
            for (std::size_t k = 0; k < setup.shape_choices.size(); ++k) {
              ImGui::SameLine();
              const std::string label = fmt::format("{}##cube{}", setup.shape_choices[k], cube);
              if (ImGui::RadioButton(label.c_str(), shape_choice_[cube] == static_cast<int>(k)))
                shape_choice_[cube] = static_cast<int>(k);
            }
          }
          const bool all =
              std::all_of(shape_choice_.begin(), shape_choice_.end(), [](int c) { return c >= 0; });
          ImGui::BeginDisabled(!all);
          if (ImGui::Button("Submit")) submit_shapes();
          ImGui::EndDisabled();
          break;
        }
        case training::StudyKind::Diagnosis: {
          // Marks with a grade, the countdown, End case.
          ImGui::TextWrapped(
              "Find the carious lesions. Hold the tip on a suspected lesion and press M (or "
              "the device's button) to mark it with the grade shown here (keys 1 and 2 choose "
              "it); End case when done.");
          if (setup.time_limit > 0.0)
            ImGui::Text("time left %s", clock_text(setup.time_limit - snapshot_.t).c_str());
          panel_grade();
          if (ImGui::Button("Mark (M)")) study_mark();
          ImGui::SameLine();
          if (ImGui::Button("End case")) {
            run_->end_case(snapshot_.t);
            end_trial();
            break;
          }
          const auto& marks = run_->answers().marks;
          ImGui::Text("%zu marks", marks.size());
          for (std::size_t i = 0; i < marks.size(); ++i)
            ImGui::BulletText("%s at %s", std::string(training::grade_name(marks[i].grade)).c_str(),
                              clock_text(marks[i].t).c_str());
          break;
        }
      }
    }
  }
  if (!study_message_.empty()) {
    if (study_message_is_error_) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.4f, 0.4f, 1.0f));
    ImGui::TextWrapped("%s", study_message_.c_str());
    if (study_message_is_error_) ImGui::PopStyleColor();
  }
}

void ViewerApp::panel_grade() {
  // The grade of the next mark, large enough to read from the chair with the stylus in hand: two
  // half-width buttons at twice the text size, the chosen one lit (the mouse still chooses).
  ImGui::Text("grade of the next mark (1 mild, 2 severe):");
  constexpr float kScale = 2.0f;
  const float width = 0.5f * (ImGui::GetContentRegionAvail().x - ImGui::GetStyle().ItemSpacing.x);
  const ImVec4 lit[2] = {ImVec4(0.80f, 0.60f, 0.10f, 1.0f), ImVec4(0.75f, 0.18f, 0.12f, 1.0f)};
  ImGui::SetWindowFontScale(kScale);
  for (int g = 0; g < 2; ++g) {
    if (g > 0) ImGui::SameLine();
    const bool chosen = grade_choice_ == g;
    ImGui::PushStyleColor(ImGuiCol_Button, chosen ? lit[g] : ImVec4(0.18f, 0.18f, 0.20f, 1.0f));
    ImGui::PushStyleColor(ImGuiCol_Text, chosen ? ImVec4(1, 1, 1, 1) : ImVec4(0.45f, 0.45f, 0.45f, 1.0f));
    if (ImGui::Button(g == 0 ? "MILD##grade" : "SEVERE##grade", ImVec2(width, 0.0f))) grade_choice_ = g;
    ImGui::PopStyleColor(2);
    if (chosen) {
      const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
      grade_box_ = {lo.x, lo.y, hi.x - lo.x, hi.y - lo.y};
    }
  }
  ImGui::SetWindowFontScale(1.0f);
}

void ViewerApp::study_json(io::JsonWriter& json) const {
  // The study's progress as the panel shows it (nothing of what the trial hides).
  json.key("study");
  if (!course_ || !study_) {
    json.null();
    return;
  }
  json.begin_object();
  json.field("course", course_->name);
  json.field("station", course_->station);
  json.field("name", study_->name);
  json.field("kind", std::string(training::study_kind_name(study_->kind)));
  json.field("participant", run_ ? run_->options().participant : std::string());
  json.field("trials", run_ ? run_->trial_count() : 0);
  json.field("trial", run_ ? run_->current_trial() : 0);
  json.field("in_trial", run_ && run_->in_trial());
  json.field("finished", study_finished());
  json.field("ended", static_cast<int>(results_.size()));
  json.field("marks", run_ && run_->in_trial() ? static_cast<int>(run_->answers().marks.size()) : 0);
  // The grade of the next mark, and where the panel shows it (px; zero size when not shown).
  json.field("grade", std::string(grade_choice_ == 0 ? "mild" : "severe"));
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  json.key("grade_box").begin_object();
  json.field("x", static_cast<double>(grade_box_[0] * scale.x))
      .field("y", static_cast<double>(grade_box_[1] * scale.y));
  json.field("w", static_cast<double>(grade_box_[2] * scale.x))
      .field("h", static_cast<double>(grade_box_[3] * scale.y));
  json.end_object();
  json.field("database", course_->database().string());
  json.field("message", study_message_);
  json.end_object();
}

}  // namespace cariesim::viewer
