// Paper §5.3, Figs. 15-16: scripted probing in `oral-cavity`. For each lesion the haptic tool slides
// from healthy enamel onto the (hidden) lesion, pushes in to its bottom, holds, and pulls out; the
// normal force is recorded over the interaction states, and each lesion's deepest insertion is
// compared with its authored depth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "experiment/common.hpp"
#include "experiment/oral.hpp"

namespace cariesim::experiment {

namespace {

constexpr double kApproach = 3.0;     // mm above the surface where each probe starts
constexpr double kSlide = 1.5;        // mm of sliding on enamel before reaching the lesion's centre
constexpr double kPress = 0.3;        // mm below the surface while sliding
constexpr double kPushSpeed = 2.0;    // mm/s
constexpr double kBeyondBottom = 1.5; // mm the haptic tip goes past where the lag would put it
constexpr double kNearTip = 1.5;      // mm: tool leaves this close to the tip may touch the lesion's tooth
constexpr double kGoodClearance = 0.3; // mm: a posture this clear of everything is a correct one

// An orthonormal pair spanning the plane perpendicular to n: the tangent basis about world z, turned
// by half a turn (u = z × n / |z × n|, v = n × u), which is how the posture candidates are laid out.
void plane_basis(const Vec3& n, Vec3& u, Vec3& v) {
  tangent_basis(n, u, v, 2);
  u = -u;
  v = -v;
}

}  // namespace

Quat probe_orientation(const Vec3& axis, double roll) {
  // Tool +z along `axis` (the tip points against it), tool +x (where the working end bends) at `roll`.
  Vec3 u, v;
  plane_basis(axis, u, v);
  Mat3 r;
  r.col(2) = axis.normalized();
  r.col(0) = std::cos(roll) * u + std::sin(roll) * v;
  r.col(1) = r.col(2).cross(r.col(0));
  return Quat(r).normalized();
}

Posture evaluate_posture(const Model& model, const LesionModel& lesion, const Quat& q) {
  // Poses along the insertion axis: above the surface, at the surface, at the lesion's floor.
  const Vec3 n = lesion.shape.normal.normalized();
  const Vec3 axis = q * Vec3::UnitZ();
  const Vec3 s = lesion.shape.center;
  const double r_tip = model.tool.tip_radius;
  PlacedTool placed(model.tool.tree);
  std::vector<double> margin(model.tool.tree.leaf_count(), 0.0);
  for (std::size_t i = 0; i < margin.size(); ++i) {
    const Vec3 c = model.tool.tree.nodes[model.tool.tree.leaf_nodes[i]].center.cast<double>();
    margin[i] = c.norm() > kNearTip ? 2.0 : 0.0;  // only leaves away from the tip are judged
  }
  ObjectMask mask = kAllObjects;
  if (lesion.object >= 0) mask &= ~(ObjectMask{1} << lesion.object);
  ContactSet contacts(4096);
  Posture out;
  out.q = q;
  out.tilt = std::acos(std::clamp(axis.dot(n), -1.0, 1.0));
  out.clearance = 2.0;
  const double floor = lesion.authored_depth / std::max(axis.dot(n), 0.2);
  for (double depth : {-kApproach, 0.0, floor}) {
    placed.place(Pose{s - axis * (depth - r_tip), q}, margin);
    contacts.clear();
    collide(placed, model.objects, mask, contacts);
    for (const Contact& c : contacts.view()) {
      if (c.gap < out.clearance) out.clearance = c.gap, out.nearest_object = c.object;
    }
  }
  return out;
}

std::vector<Posture> posture_candidates(const Model& model, const LesionModel& lesion) {
  const Vec3 n = lesion.shape.normal.normalized();
  Vec3 u, v;
  plane_basis(n, u, v);
  std::vector<Posture> out;
  for (int t = 0; t <= 3; ++t) {
    const double tilt = t * M_PI / 18.0;  // 0, 10, 20, 30 degrees
    for (int a = 0; a < (t == 0 ? 1 : 8); ++a) {
      const double azimuth = a * M_PI / 4.0;
      const Vec3 axis = std::cos(tilt) * n + std::sin(tilt) * (std::cos(azimuth) * u + std::sin(azimuth) * v);
      for (int k = 0; k < 24; ++k) out.push_back(evaluate_posture(model, lesion, probe_orientation(axis, k * M_PI / 12.0)));
    }
  }
  return out;
}

Posture best_posture(const Model& model, const LesionModel& lesion) {
  const std::vector<Posture> all = posture_candidates(model, lesion);
  const Posture* best = nullptr;
  for (const Posture& p : all) {
    const bool good = p.clearance >= kGoodClearance;
    if (best == nullptr) {
      best = &p;
      continue;
    }
    const bool best_good = best->clearance >= kGoodClearance;
    if (good && (!best_good || p.tilt < best->tilt - 1e-9 ||
                 (std::abs(p.tilt - best->tilt) < 1e-9 && p.clearance > best->clearance)))
      best = &p;
    else if (!good && !best_good && p.clearance > best->clearance)
      best = &p;
  }
  return *best;
}

double apex_depth(const Model& model, const LesionModel& lesion, const Pose& graphic) {
  const Vec3 n = lesion.shape.normal.normalized();
  const Vec3 apex = graphic.p - graphic.z_axis() * model.tool.tip_radius;
  return (lesion.shape.center - apex).dot(n);
}

Trajectory probe_trajectory(const Model& model, const LesionModel& lesion, const Quat& q, double* push_start,
                            double* push_end) {
  const Vec3 n = lesion.shape.normal.normalized();
  const Vec3 axis = q * Vec3::UnitZ();  // toward the handle; the tip goes in along -axis
  const Vec3 s = lesion.shape.center;
  const double r_tip = model.tool.tip_radius;
  const Material& mat = model.defaults.materials[lesion.material];
  Vec3 u, v;
  plane_basis(n, u, v);
  // Tip centre for an apex `depth` along the axis below the surface point `p` (mm).
  const auto tip = [&](const Vec3& p, double depth) { return at(p - axis * (depth - r_tip), q); };
  const Vec3 healthy = s + u * kSlide;  // enamel next to the lesion (approximately on the surface)
  Path path(tip(healthy, -kApproach));
  path.to(1.0, tip(healthy, kPress)).hold(0.3);  // touch the enamel
  path.to(1.0, tip(s, kPress)).hold(0.3);        // slide onto the lesion
  if (push_start != nullptr) *push_start = path.end();
  // Push to the floor: the graphic tip lags the haptic by F_p*/k_e (eqs. 3-5).
  const double floor = lesion.authored_depth / std::max(axis.dot(n), 0.2);
  const double deepest = floor + mat.f_p_star / mat.k_e + kBeyondBottom;
  path.to((deepest - kPress) / kPushSpeed, tip(s, deepest)).hold(0.5);
  if (push_end != nullptr) *push_end = path.end();
  path.to((deepest + kApproach) / kPushSpeed, tip(s, -kApproach));  // pull out and away
  return path.trajectory();
}

void run_oral(const ExperimentOptions& options, io::JsonWriter& summary) {
  say(options, "oral: building oral-cavity");
  const Model model = build_model(load_scene("oral-cavity", options.overrides), options.build);
  summary.field("experiment", "oral").field("paper", "Figs. 15-16, §5.3").key("lesions").begin_array();
  double state_force[4] = {0, 0, 0, 0};
  int state_count[4] = {0, 0, 0, 0};
  RunChecks checks;
  for (std::size_t l = 0; l < model.lesions.size(); ++l) {
    const LesionModel& lesion = model.lesions[l];
    const Material& mat = model.defaults.materials[lesion.material];
    double push_start = 0.0, push_end = 0.0;
    const Posture posture = best_posture(model, lesion);
    const Trajectory trajectory = probe_trajectory(model, lesion, posture.q, &push_start, &push_end);
    const std::vector<SimSample> samples = simulate(model, trajectory, options.rate_hz);
    checks.add(model, samples);

    // Deepest insertion into this lesion; force by state; the entry's insertion force.
    double max_depth = 0.0, max_insertion = 0.0, entry_time = -1.0, first_contact = -1.0;
    std::vector<std::vector<double>> rows;
    std::vector<std::string> states;
    for (const SimSample& s : samples) {
      const bool inside = penetrating(s.out.state);
      if (inside && s.out.lesion == static_cast<int>(l)) {
        max_depth = std::max(max_depth, apex_depth(model, lesion, s.out.graphic));
        max_insertion = std::max(max_insertion, s.out.depth);
      }
      if (inside && entry_time < 0.0) entry_time = s.t;
      if (s.out.state != InteractionState::Free && first_contact < 0.0) first_contact = s.t;
      state_force[static_cast<int>(s.out.state)] += s.out.normal_force;
      ++state_count[static_cast<int>(s.out.state)];
      rows.push_back({s.t, s.out.normal_force, s.out.force.norm(), s.out.depth, static_cast<double>(s.out.tip_tissue)});
      states.push_back(state_name(s.out.state));
    }
    const std::string csv = "oral_" + lesion.name + ".csv";
    write_csv(options.out / csv, {"t", "normal_force", "force", "depth", "tip_tissue", "state"}, rows,
              states);
    say(options, "oral: " + lesion.name + ": authored depth " + std::to_string(lesion.authored_depth) +
                     " mm, reached " + std::to_string(max_depth) + " mm (posture clearance " +
                     std::to_string(posture.clearance) + " mm, tilt " +
                     std::to_string(posture.tilt * 180.0 / M_PI) + " deg)");
    summary.begin_object()
        .field("name", lesion.name)
        .field("severity", lesion.severity)
        .field("authored_depth_mm", lesion.authored_depth)
        .field("max_depth_mm", max_depth)
        .field("depth_error_mm", max_depth - lesion.authored_depth)
        .field("max_insertion_mm", max_insertion)
        .field("F_p_threshold_N", mat.f_p_star)
        .field("F_e_threshold_N", mat.f_e_star)
        .field("k_e", mat.k_e)
        .field("k_c_top", mat.k_c.at(0.0))
        .field("posture_clearance_mm", posture.clearance)
        .field("posture_tilt_deg", posture.tilt * 180.0 / M_PI)
        .field("time_to_insertion_s", entry_time >= 0.0 ? entry_time - first_contact : -1.0)
        .field("push_start_s", push_start)
        .field("push_end_s", push_end)
        .field("csv", csv)
        .end_object();
  }
  summary.end_array();
  checks.write(summary);
  summary.key("mean_normal_force_by_state").begin_object();
  const char* names[] = {"free", "sliding", "inserting", "extracting"};
  for (int i = 0; i < 4; ++i) summary.field(names[i], state_count[i] ? state_force[i] / state_count[i] : 0.0);
  summary.end_object();
}

}  // namespace cariesim::experiment
