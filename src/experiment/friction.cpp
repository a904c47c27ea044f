// Paper §4.1.1, Figs. 9-11: friction force signals along a predefined 1-D path. The haptic tip goes
// down into the friction block until its apex is 0.59 mm below the (carious) surface, slides along
// x, and comes back up; four mu_s with mu_d = 0.3 (Fig. 10), four mu_d with mu_s = 0.5 (Fig. 11).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "cariesim/common/error.hpp"
#include "cariesim/render/material.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "experiment/common.hpp"
#include "experiment/enamel_slide.hpp"

namespace cariesim::experiment {

namespace {

constexpr double kPressDepth = 0.59;   // mm, haptic apex below the surface (paper §4.1.1)
constexpr double kSlideLength = 30.0;  // mm
constexpr double kSlideSpeed = 10.0;   // mm/s
constexpr double kSettle = 0.3;        // s after the slide starts before the signal is measured

struct Run {
  const char* group;  // "static" (Fig. 10) or "dynamic" (Fig. 11)
  double mu_s, mu_d;
};

// How smooth scanned enamel feels (docs/step.md, "Force shading"): the frictionless slide over the
// real arch's 46 (experiment/enamel_slide.hpp) with force shading and, for comparison, without it
// (the force of the sphere pairs' own normals); the tangential force of both along the slide goes to
// enamel_slide.csv (the figure enamel_ripple.png), the ripple and the presets' friction at the same
// load to the summary, with the same slide's ripples on the premolar 44.
void enamel_ripple(const ExperimentOptions& options, io::JsonWriter& summary, RunChecks& checks) {
  say(options, "friction: building real-arch (the enamel slide)");
  Model arch = build_model(load_scene("real-arch", options.overrides), options.build);
  Params frictionless = arch.defaults;
  for (Material& m : frictionless.materials) m.mu_s = m.mu_d = m.mu_s_along = m.mu_d_along = 0.0;
  const bool shading = arch.settings.force_shading;  // the step's default
  arch.settings.force_shading = false;
  const EnamelSlide spheres = enamel_slide(arch, frictionless, options.rate_hz);
  const EnamelSlide premolar_spheres =
      enamel_slide(arch, frictionless, premolar_buccal_slide(), options.rate_hz);
  arch.settings.force_shading = true;
  const EnamelSlide shaded = enamel_slide(arch, frictionless, options.rate_hz);
  const EnamelSlide premolar = enamel_slide(arch, frictionless, premolar_buccal_slide(), options.rate_hz);
  checks.rigid_penetration =
      std::max({checks.rigid_penetration, spheres.max_rigid_penetration, shaded.max_rigid_penetration,
                premolar_spheres.max_rigid_penetration, premolar.max_rigid_penetration});
  std::vector<std::vector<double>> rows;
  const auto add = [&](const EnamelSlide& slide, double shaded_flag) {
    for (std::size_t i = 0; i < slide.s.size(); ++i)
      rows.push_back({shaded_flag, slide.s[i], slide.along[i], slide.across[i], slide.normal[i]});
  };
  add(spheres, 0.0);
  add(shaded, 1.0);
  write_csv(options.out / "enamel_slide.csv", {"shaded", "s_mm", "f_along", "f_across", "f_normal"}, rows);
  const double mild = caries_preset(CariesPreset::Mild).mu_d * kEnamelSlideLoad;
  const double severe = caries_preset(CariesPreset::Severe).mu_d * kEnamelSlideLoad;
  say(options, "friction: enamel slide ripple " + std::to_string(shaded.ripple) + " N (sphere normals " +
                   std::to_string(spheres.ripple) + " N)");
  summary.key("enamel_slide")
      .begin_object()
      .field("scene", "real-arch")
      .field("surface", "tooth46 buccal, frictionless")
      .field("normal_load_N", kEnamelSlideLoad)
      .field("speed_mm_s", kEnamelSlideSpeed)
      .field("window_mm", kEnamelRippleWindow)
      .field("force_shading_by_default", shading)
      .field("ripple_N", shaded.ripple)
      .field("ripple_sphere_normals_N", spheres.ripple)
      .field("mean_normal_N", shaded.mean_normal)
      .field("free_steps", shaded.free_steps.size())
      .field("mild_friction_N", mild)
      .field("severe_friction_N", severe)
      .field("mild_friction_over_ripple", shaded.ripple > 0.0 ? mild / shaded.ripple : 0.0)
      .field("csv", "enamel_slide.csv");
  // The same slide on a premolar's more curved face (44, experiment/enamel_slide.hpp).
  summary.key("premolar")
      .begin_object()
      .field("surface", "tooth44 buccal, frictionless")
      .field("ripple_N", premolar.ripple)
      .field("ripple_sphere_normals_N", premolar_spheres.ripple)
      .field("mean_normal_N", premolar.mean_normal)
      .field("free_steps", premolar.free_steps.size())
      .end_object();
  summary.end_object();
}

}  // namespace

void run_friction(const ExperimentOptions& options, io::JsonWriter& summary) {
  say(options, "friction: building friction-block");
  const Model model = build_model(load_scene("friction-block", options.overrides), options.build);
  if (model.lesions.empty()) throw Error("friction-block: the scene has no carious top");
  const LesionModel& top = model.lesions.front();
  const Vec3 surface = top.shape.center;  // a point on the carious top, normal +z
  const Quat q = model.tool_home.q;
  const double r_tip = model.tool.tip_radius;

  // Fig. 9's path: down at the start, along x at constant depth, back up.
  const Vec3 start = surface + Vec3(-kSlideLength / 2.0, 0.0, 0.0);
  const double press_z = surface.z() + r_tip - kPressDepth;
  Path path(at(start + Vec3(0, 0, 2.0), q));
  path.to(0.5, at(Vec3(start.x(), start.y(), press_z), q));
  const double slide_start = path.end();
  path.to(kSlideLength / kSlideSpeed, at(Vec3(start.x() + kSlideLength, start.y(), press_z), q));
  const double slide_end = path.end();
  path.to(0.5, at(Vec3(start.x() + kSlideLength, start.y(), surface.z() + 2.0), q));

  const Run runs[] = {{"static", 0.2, 0.3}, {"static", 0.4, 0.3}, {"static", 0.6, 0.3}, {"static", 0.8, 0.3},
                      {"dynamic", 0.5, 0.1}, {"dynamic", 0.5, 0.2}, {"dynamic", 0.5, 0.3}, {"dynamic", 0.5, 0.4}};
  summary.field("experiment", "friction").field("paper", "Figs. 9-11").field("press_depth_mm", kPressDepth);
  summary.field("slide_speed_mm_s", kSlideSpeed).key("runs").begin_array();
  RunChecks checks;
  for (const Run& run : runs) {
    // The carious top's materials get this run's coefficients.
    Params params = model.defaults;
    for (Material& m : params.materials) {
      if (m.lesion != 0) continue;
      m.mu_s = run.mu_s;
      m.mu_d = run.mu_d;
    }
    const std::vector<SimSample> samples = simulate(model, params, path.trajectory(), options.rate_hz);
    checks.add(model, samples);

    // The signal: F_x over the slide, the slip events (saw-tooth drops).
    const double t0 = slide_start + kSettle, t1 = slide_end;
    const Stats fx = abs_stats(samples, t0, t1, [](const SimSample& s) { return s.out.force.x(); });
    const Stats fz = abs_stats(samples, t0, t1, [](const SimSample& s) { return s.out.force.z(); });
    int slips = 0;
    std::vector<std::vector<double>> rows;
    for (const SimSample& s : samples) {
      if (s.t >= t0 && s.t <= t1) slips += s.out.slips;
      rows.push_back({s.t, s.out.haptic.p.x(), s.out.graphic.p.x(), s.out.force.x(), s.out.force.z(),
                      static_cast<double>(s.out.slips)});
    }
    char name[64];
    std::snprintf(name, sizeof name, "friction_%s_mus%.2f_mud%.2f.csv", run.group, run.mu_s, run.mu_d);
    write_csv(options.out / name, {"t", "h_x", "g_x", "fx", "fz", "slips"}, rows);
    say(options, std::string("friction: ") + name + ": mean |Fx| " + std::to_string(fx.mean) + " N, slips " +
                     std::to_string(slips));
    summary.begin_object()
        .field("figure", run.group[0] == 's' ? "Fig. 10" : "Fig. 11")
        .field("mu_s", run.mu_s)
        .field("mu_d", run.mu_d)
        .field("mean_abs_fx", fx.mean)
        .field("peak_abs_fx", fx.peak)
        .field("mean_fz", fz.mean)
        .field("slip_events", slips)
        .field("csv", name)
        .end_object();
  }
  summary.end_array();
  summary.field("measured_from_s", slide_start + kSettle).field("measured_to_s", slide_end);
  enamel_ripple(options, summary, checks);
  checks.write(summary);
}

}  // namespace cariesim::experiment
