// Paper §5.1, Fig. 14: insertion and extraction with simultaneous contacts on `insertion-blocks`
// (k_e 1, k_c 10, k_p 1 N/mm, F_p* 3 N). A scripted haptic tool goes through five phases:
// (1) no contact, (2) contact without insertion, (3) insertion, (4) insertion with an additional
// contact (the shank comes down onto the rigid healthy cube), (5) extraction, then free again.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "experiment/common.hpp"

namespace cariesim::experiment {

namespace {

constexpr double kTipX = -2.0;      // mm: the probe enters 1.5 mm from the caries cube's edge
constexpr double kContactIn = 2.0;  // mm: phase 2 pushes the haptic tip this deep (F_p < F_p*)
constexpr double kDeepest = 9.0;    // mm: the haptic tip's deepest point

const char* kPhases[] = {"no_contact", "contact", "insertion", "insertion_with_contact",
                         "extraction", "free"};

// The phase a sample belongs to, given what came before it.
int phase_of(const SimSample& s, bool inserted_before) {
  switch (s.out.state) {
    case InteractionState::Inserting:
      return s.out.contacts > 0 ? 3 : 2;
    case InteractionState::Extracting:
      return 4;
    case InteractionState::Sliding:
      return inserted_before ? 5 : 1;
    case InteractionState::Free:
      return inserted_before ? 5 : 0;
  }
  return 0;
}

// One run of the k_c sweep: a caries material inserted into at 2 mm/s.
struct SweepRun {
  std::string name;
  Material material;
};

// The k_c sweep (docs/penetration.md): the presets, k_c alone from 0.2 to 1.5 N/mm (the mild preset
// otherwise, k_e 1 N/mm), a two-layer and a graded lesion. Each is inserted at 2 mm/s, a clinical
// hand speed; the felt axial force is written against the apex depth.
std::vector<SweepRun> sweep_runs() {
  std::vector<SweepRun> runs;
  runs.push_back({"mild preset", caries_preset(CariesPreset::Mild)});
  runs.push_back({"severe preset", caries_preset(CariesPreset::Severe)});
  Material base = caries_preset(CariesPreset::Mild);
  base.k_e = 1.0;
  for (const double k_c : {0.2, 0.4, 0.58, 1.0, 1.5}) {
    Material m = base;
    m.k_c.values.fill(k_c);
    runs.push_back({fmt::format("k_c {:g}", k_c), m});
  }
  Material layered = base;
  layered.k_c.kind = KcProfile::Kind::Layers;
  layered.k_c.layer_count = 2;
  layered.k_c.values = {0.3, 0.6, 0.6, 0.6};
  layered.k_c.bounds = {1.5, 50.0, 0.0, 0.0};
  runs.push_back({"layers 0.3 / 0.6 at 1.5 mm", layered});
  Material graded = base;
  graded.k_c.kind = KcProfile::Kind::Gradient;
  graded.k_c.values = {0.2, 0.8, 0.0, 0.0};
  graded.k_c.bounds = {3.0, 0.0, 0.0, 0.0};
  runs.push_back({"gradient 0.2 to 0.8 over 3 mm", graded});
  return runs;
}

constexpr double kSweepSpeed = 2.0;  // mm/s, the hand's insertion speed in the k_c sweep

// Runs the k_c sweep on `base` (insertion-blocks) and writes kc_sweep.csv and the summary's "kc_sweep".
void run_kc_sweep(const ExperimentOptions& options, const Model& base, const Trajectory& push,
                  RunChecks& checks, io::JsonWriter& summary) {
  say(options, "insertion: k_c sweep at 2 mm/s");
  std::vector<std::vector<double>> rows;
  std::vector<std::string> names;
  summary.key("kc_sweep").begin_array();
  double mild = 0.0, severe = 0.0;
  int index = 0;
  for (const SweepRun& run : sweep_runs()) {
    Model model = base;
    Material& caries = model.defaults.materials[model.lesions.front().material];
    const int16_t lesion = caries.lesion;
    caries = run.material;
    caries.lesion = lesion;
    const std::vector<SimSample> samples = simulate(model, push, options.rate_hz);
    checks.add(model, samples);
    // Mean felt axial force with the apex 0.5-2 mm deep, and the curve of force against depth.
    double sum = 0.0;
    int n = 0;
    for (const SimSample& s : samples) {
      if (s.out.state != InteractionState::Inserting) continue;
      rows.push_back({static_cast<double>(index), s.t, s.out.depth, s.out.force.z()});
      names.push_back(run.name);
      if (s.out.depth >= 0.5 && s.out.depth < 2.0) sum += s.out.force.z(), ++n;
    }
    const double mean = n > 0 ? sum / n : 0.0;
    if (index == 0) mild = mean;
    if (index == 1) severe = mean;
    summary.begin_object().field("name", run.name).field("k_c_top", run.material.k_c.at(0.0));
    summary.field("k_e", run.material.k_e).field("crush_length_mm", run.material.crush_length);
    summary.field("f_p_star", run.material.f_p_star);
    summary.field("resistance_N", insertion_resistance(run.material, 1.0));
    summary.field("mean_axial_force_N", mean).end_object();
    say(options, fmt::format("insertion: {}: mean axial force {:.3f} N at 0.5-2 mm", run.name, mean));
    ++index;
  }
  summary.end_array();
  summary.field("kc_sweep_speed_mm_s", kSweepSpeed);
  summary.field("mild_severe_force_ratio", severe > 0.0 ? mild / severe : 0.0);
  write_csv(options.out / "kc_sweep.csv", {"run", "t", "depth", "f_axial", "name"}, rows, names);
  summary.field("kc_sweep_csv", "kc_sweep.csv");
}

}  // namespace

void run_insertion(const ExperimentOptions& options, io::JsonWriter& summary) {
  say(options, "insertion: building insertion-blocks");
  const Model model = build_model(load_scene("insertion-blocks", options.overrides), options.build);
  if (model.lesions.empty()) throw Error("insertion-blocks: the scene has no lesion");
  const LesionModel& lesion = model.lesions.front();
  const Material& caries = model.defaults.materials[lesion.material];
  const double top = lesion.shape.center.z();
  const double r_tip = model.tool.tip_radius;
  const Quat upright = Quat::Identity();  // tip down, working end and shank out over the healthy cube

  // The scripted haptic tool (tip centre positions).
  const auto tip = [&](double depth) { return at(Vec3(kTipX, 0.0, top + r_tip - depth), upright); };
  Path path(tip(-4.0));
  path.to(1.0, tip(-0.2));                  // (1) approach without contact
  path.to(1.0, tip(kContactIn)).hold(0.5);  // (2) press, below F_p*
  path.to(4.0, tip(kDeepest)).hold(0.5);    // (3)-(4) push in until the shank meets the healthy cube
  path.to(5.0, tip(-1.0));                  // (5) pull out
  path.to(1.0, tip(-4.0));                  // free again
  const std::vector<SimSample> samples = simulate(model, path.trajectory(), options.rate_hz);

  // Clearance to the healthy (rigid) cube while inserted: it must not be entered.
  ObjectMask healthy = 0;
  for (std::size_t i = 0; i < model.objects.size(); ++i)
    if (model.objects[i].lesion < 0 && model.objects[i].name.find("healthy") != std::string::npos)
      healthy |= ObjectMask{1} << i;
  PlacedTool placed(model.tool.tree);

  // Phases, per-phase statistics, tip deviation from the tunnel axis.
  struct PhaseStats {
    double t_start = -1.0, t_end = -1.0, max_depth = 0.0, force_sum = 0.0;
    int n = 0;
  };
  PhaseStats phases[6];
  bool inserted = false;
  double axis_deviation = 0.0, min_clearance = std::numeric_limits<double>::infinity();
  std::vector<std::vector<double>> rows;
  std::vector<std::string> states;
  for (const SimSample& s : samples) {
    const bool inside = penetrating(s.out.state);
    inserted = inserted || inside;
    const int p = phase_of(s, inserted && !inside);
    PhaseStats& ph = phases[p];
    if (ph.t_start < 0.0) ph.t_start = s.t;
    ph.t_end = s.t;
    ph.max_depth = std::max(ph.max_depth, s.out.depth);
    ph.force_sum += s.out.force.norm();
    ++ph.n;
    if (inside && s.out.tunnel.active) {
      const Vec3 d = s.out.graphic.p - s.out.tunnel.entry;
      axis_deviation = std::max(axis_deviation, (d - s.out.tunnel.axis * d.dot(s.out.tunnel.axis)).norm());
      placed.place(s.out.graphic, 0.0);
      const ClosestPair c = closest(placed, model.objects, healthy, 1.0);
      if (std::isfinite(c.gap)) min_clearance = std::min(min_clearance, c.gap);
    }
    const double f_axis = s.out.force.z();  // the axis is vertical
    rows.push_back({s.t, top - (s.out.haptic.p.z() - r_tip), top - (s.out.graphic.p.z() - r_tip), s.out.depth,
                    f_axis, s.out.force.norm(), static_cast<double>(s.out.contacts), static_cast<double>(p)});
    states.push_back(state_name(s.out.state));
  }
  write_csv(options.out / "insertion.csv",
            {"t", "haptic_apex_depth", "graphic_apex_depth", "depth", "f_z", "f_norm", "contacts", "phase",
             "state"},
            rows, states);

  summary.field("experiment", "insertion").field("paper", "Fig. 14, §5.1");
  summary.field("k_e", caries.k_e)
      .field("k_c", caries.k_c.at(0.0))
      .field("k_p", model.defaults.limits.max_stiffness);
  summary.field("f_p_star", caries.f_p_star).field("f_e_star", caries.f_e_star);
  summary.key("phases").begin_array();
  for (int i = 0; i < 6; ++i) {
    summary.begin_object().field("name", kPhases[i]).field("t_start", phases[i].t_start);
    summary.field("t_end", phases[i].t_end).field("max_depth", phases[i].max_depth);
    summary.field("mean_force", phases[i].n ? phases[i].force_sum / phases[i].n : 0.0).end_object();
    say(options, std::string("insertion: ") + kPhases[i] + " " + std::to_string(phases[i].t_start) + " - " +
                     std::to_string(phases[i].t_end) + " s, max depth " +
                     std::to_string(phases[i].max_depth));
  }
  summary.end_array();
  summary.field("max_tip_axis_deviation_mm", axis_deviation);
  summary.field("min_healthy_clearance_mm", std::isfinite(min_clearance) ? min_clearance : 1.0);
  RunChecks checks;
  checks.add(model, samples);
  summary.field("csv", "insertion.csv");

  // The k_c sweep: the hand comes down at 2 mm/s from 1 mm above the caries for 4.5 s.
  constexpr double kSweepSeconds = 4.5;
  const Trajectory push =
      Path(tip(-1.0)).to(kSweepSeconds, tip(-1.0 + kSweepSpeed * kSweepSeconds)).trajectory();
  run_kc_sweep(options, model, push, checks, summary);
  checks.write(summary);
}

}  // namespace cariesim::experiment
