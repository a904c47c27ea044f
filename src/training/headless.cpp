// A study without a window (docs/training.md, "headless"): answers files, and each trial run as a
// recorded Session driven by a scripted device, then answered from the file and ended. A hardware
// device's buttons mark and end a diagnosis case as its profile maps them, as in the viewer.

#include "cariesim/training/headless.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/profile.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/servo/session.hpp"
#include "training/scores.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

using io::Fields;
using io::indexed;
using io::Reader;

namespace {

namespace fs = std::filesystem;

constexpr double kMaxAnswerTime = 3600.0;  // s, latest time an answers file may name
constexpr double kDefaultDuration = 1.0;   // s of a trial whose device does not end

// A device spec with a relative FILE (scripted:FILE, replay:FILE) taken from the answers file's folder.
std::string resolve_device(const std::string& spec, const fs::path& origin) {
  for (const std::string_view prefix : {"scripted:", "replay:"}) {
    if (!spec.starts_with(prefix)) continue;
    const fs::path file(spec.substr(prefix.size()));
    if (file.is_absolute() || origin.parent_path().empty()) return spec;
    return std::string(prefix) + (origin.parent_path() / file).string();
  }
  return spec;
}

// One entry of `trials`.
ScriptedTrial read_trial(const Reader& r, const YAML::Node& node, const std::string& path,
                         const fs::path& origin) {
  const Fields f(r, node, path, {"tuning", "shapes", "marks", "buttons", "end", "device"});
  ScriptedTrial t;
  t.where = SourceLoc{r.file(), node.Mark().line + 1, node.Mark().column + 1};
  if (const auto n = f.get("tuning"); n.IsDefined()) {
    const Fields levels(r, n, f.sub("tuning"), {"mild", "severe"});
    for (const std::string_view level : {"mild", "severe"}) {
      if (!levels.has(level)) continue;
      const Fields values(r, levels.get(level), levels.sub(level),
                          {kScoreMuS, kScoreMuD, kScoreKc, kScoreKe});
      for (const std::string_view name : {kScoreMuS, kScoreMuD, kScoreKc, kScoreKe}) {
        if (values.has(name))
          t.tuning[std::string(level)][std::string(name)] = r.number(values.get(name), values.sub(name));
      }
    }
  }
  if (const auto n = f.get("shapes"); n.IsDefined()) {
    r.require_sequence(n, f.sub("shapes"));
    for (std::size_t i = 0; i < n.size(); ++i) t.shapes.push_back(r.text(n[i], indexed(f.sub("shapes"), i)));
  }
  if (const auto n = f.get("marks"); n.IsDefined()) {
    r.require_sequence(n, f.sub("marks"));
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string mark_path = indexed(f.sub("marks"), i);
      const Fields m(r, n[i], mark_path, {"t", "at", "grade"});
      ScriptedMark mark;
      mark.t = r.number_in(m.require("t"), m.sub("t"), 0.0, kMaxAnswerTime, "s");
      if (const auto at = m.get("at"); at.IsDefined()) mark.at = r.vec3(at, m.sub("at"));
      mark.grade = r.choice(m.require("grade"), m.sub("grade"), "grade", {"mild", "severe"}) == 0
                       ? Grade::Mild
                       : Grade::Severe;
      t.marks.push_back(mark);
    }
  }
  if (const auto n = f.get("buttons"); n.IsDefined()) {
    const Fields b(r, n, f.sub("buttons"), {"mild", "severe"});
    if (const auto m = b.get("mild"); m.IsDefined())
      t.mild_button = static_cast<int>(r.integer_in(m, b.sub("mild"), 0, 31));
    if (const auto m = b.get("severe"); m.IsDefined())
      t.severe_button = static_cast<int>(r.integer_in(m, b.sub("severe"), 0, 31));
    if (t.mild_button >= 0 && t.mild_button == t.severe_button)
      r.fail(n, f.sub("buttons"), "mild and severe need two different buttons");
  }
  if (const auto n = f.get("end"); n.IsDefined())
    t.end = r.number_in(n, f.sub("end"), 0.0, kMaxAnswerTime, "s");
  if (const auto n = f.get("device"); n.IsDefined()) {
    t.device = r.text(n, f.sub("device"));
    if (t.device.empty()) r.fail(n, f.sub("device"), "empty device spec");
    t.device = resolve_device(t.device, origin);
  }
  return t;
}

// The recorded sample nearest to time t (s).
const ServoSample& recorded_sample(const Recording& rec, double t, const SourceLoc& where) {
  if (rec.samples.empty())
    throw Error(fmt::format("{}: a mark at t = {} s, but the trial recorded no motion", where.str(), t));
  const ServoSample* best = &rec.samples.front();
  for (const ServoSample& s : rec.samples)
    if (std::abs(s.t - t) < std::abs(best->t - t)) best = &s;
  return *best;
}

// Runs the session until the device's path ends, the servo clock reaches `limit` (s), a button the
// device's profile maps to end case is pressed (`end_on_button`), or forever for limit = infinity with
// a device that ends.
void drive(Session& session, bool ends, double limit, bool end_on_button) {
  session.start();
  bool seen_valid = false;
  ServoSnapshot snapshot;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    if (!session.latest(snapshot)) continue;
    if (snapshot.t >= limit) break;
    if (ends && seen_valid && !snapshot.device.valid) break;
    if (end_on_button && (snapshot.device.actions & kActionEndCase) != 0) break;
    seen_valid = seen_valid || snapshot.device.valid;
  }
  session.stop();
}

// What a hardware device's buttons did in a diagnosis trial, from the recorded buttons through its
// profile (docs/devices.md "Buttons"): a mark at each rising edge of mark mild / mark severe (at the
// graphic tip, touching or not), and the case's end at the first rising edge of end case.
struct ButtonAnswers {
  std::vector<Mark> marks;
  std::optional<double> end;  // s
};
ButtonAnswers answers_from_buttons(const Recording& rec, const DeviceProfile& profile) {
  ButtonAnswers out;
  uint32_t last = 0;
  for (const ServoSample& s : rec.samples) {
    const uint32_t actions = profile_actions(profile, s.buttons);
    const uint32_t pressed = actions & ~last;
    last = actions;
    if ((pressed & kActionMarkMild) != 0)
      out.marks.push_back({s.graphic.p, Grade::Mild, s.t, s.contacts > 0});
    if ((pressed & kActionMarkSevere) != 0)
      out.marks.push_back({s.graphic.p, Grade::Severe, s.t, s.contacts > 0});
    if ((pressed & kActionEndCase) != 0) {
      out.end = s.t;
      break;
    }
  }
  return out;
}

}  // namespace

ScriptedAnswers parse_answers(std::string_view yaml, const fs::path& origin) {
  const Reader r(origin.string());
  const YAML::Node root = io::parse_document(yaml, origin.string());
  if (!root.IsDefined() || root.IsNull()) throw Error(fmt::format("{}: empty answers file", origin.string()));
  const Fields f(r, root, "", {"format", "trials"});
  if (const auto n = f.get("format"); n.IsDefined()) (void)r.integer_in(n, f.sub("format"), 1, 1);
  ScriptedAnswers answers;
  answers.origin = origin.string();
  const YAML::Node trials = f.require("trials");
  r.require_sequence(trials, f.sub("trials"));
  if (trials.size() == 0) r.fail(trials, f.sub("trials"), "expected at least one trial");
  for (std::size_t i = 0; i < trials.size(); ++i)
    answers.trials.push_back(read_trial(r, trials[i], indexed(f.sub("trials"), i), origin));
  return answers;
}

ScriptedAnswers load_answers(const fs::path& file) {
  return parse_answers(io::read_file(file, "answers"), file);
}

std::vector<TrialResult> run_headless(StudyRun& run, const ScriptedAnswers& answers,
                                      const HeadlessOptions& options) {
  std::vector<TrialResult> results;
  while (!run.finished()) {
    const TrialSetup& setup = run.begin_trial();
    const std::size_t entry_index =
        std::min<std::size_t>(static_cast<std::size_t>(setup.index), answers.trials.size() - 1);
    const ScriptedTrial& entry = answers.trials[entry_index];
    const std::string context = fmt::format("trial {} ({})", setup.index + 1, entry.where.str());
    try {
      // The scene, and the session that drives and records it.
      const Model model = build_model(setup.scene(), options.build);
      SessionOptions session_options;
      session_options.scene = setup.scene_origin;
      session_options.device = entry.device.empty() ? options.device : entry.device;
      session_options.device_profile = options.device_profile;
      session_options.realtime = options.realtime;
      session_options.record = run.recording_path().string();
      if (run.study().scoring.soft_tissue_threshold)
        session_options.recorder.soft_tissue_threshold = *run.study().scoring.soft_tissue_threshold;
      Session session(model, session_options);
      const std::string& device = session.device_info().name;
      const bool ends =
          (device == "scripted" || device == "replay") && !session_options.device.ends_with(":loop");
      double limit = std::numeric_limits<double>::infinity();
      if (setup.time_limit > 0.0) limit = setup.time_limit;
      if (entry.end) limit = std::min(limit, *entry.end);
      if (!ends) limit = std::min(limit, options.duration > 0.0 ? options.duration : kDefaultDuration);
      // A hardware device (touch, fd, haply): its profile's buttons mark and end a diagnosis case.
      const auto* haptic = dynamic_cast<const HapticDevice*>(&session.device());
      drive(session, ends, limit, haptic != nullptr && setup.kind == StudyKind::Diagnosis);
      if (const Recorder* recorder = session.recorder(); recorder != nullptr && !recorder->status().ok)
        throw Error(recorder->status().message);

      // The answers, at the recorded times.
      const Recording rec = load_recording(run.recording_path());
      const double last_t = rec.samples.empty() ? 0.0 : rec.samples.back().t;
      switch (setup.kind) {
        case StudyKind::Tuning:
          for (const Grade g : setup.levels) {
            const auto level = entry.tuning.find(std::string(grade_name(g)));
            if (level == entry.tuning.end())
              throw Error(fmt::format("no tuning values for the {} level", grade_name(g)));
            run.confirm_tuning(level->second, last_t);
          }
          break;
        case StudyKind::Boundary:
          if (entry.shapes.size() != setup.cubes.size())
            throw Error(fmt::format("{} shapes named for {} cubes", entry.shapes.size(), setup.cubes.size()));
          for (std::size_t i = 0; i < entry.shapes.size(); ++i)
            run.name_shape(static_cast<int>(i), entry.shapes[i]);
          break;
        case StudyKind::Diagnosis: {
          // The file's marks, the recorded button presses the file names, and a hardware device's
          // marks and end case (its profile's buttons), in time order.
          std::vector<ScriptedMark> marks = entry.marks;
          for (const Mark& m : marks_from_buttons(rec, entry.mild_button, entry.severe_button))
            marks.push_back({m.t, m.tip, m.grade, m.contact});
          std::optional<double> end = entry.end;
          if (haptic != nullptr) {
            const ButtonAnswers pressed = answers_from_buttons(rec, haptic->profile());
            for (const Mark& m : pressed.marks) marks.push_back({m.t, m.tip, m.grade, m.contact});
            if (pressed.end && (!end || *pressed.end < *end)) end = pressed.end;
          }
          std::stable_sort(marks.begin(), marks.end(),
                           [](const ScriptedMark& a, const ScriptedMark& b) { return a.t < b.t; });
          for (const ScriptedMark& m : marks) {
            // A mark after the case's time ran out, or after its end, is not made.
            if ((setup.time_limit > 0.0 && m.t > setup.time_limit) || (end && m.t > *end)) continue;
            if (m.at) {
              run.mark(*m.at, m.grade, m.t, m.contact);
            } else {
              const ServoSample& s = recorded_sample(rec, m.t, entry.where);
              run.mark(s.graphic.p, m.grade, m.t, s.contacts > 0);
            }
          }
          if (end) run.end_case(*end);
          break;
        }
      }
      results.push_back(run.end_trial(run.recording_path(), &model));
    } catch (const Error& e) {
      throw Error(fmt::format("{}: {}", context, e.what()));
    }
    if (options.on_trial) options.on_trial(results.back());
  }
  return results;
}

}  // namespace cariesim::training
