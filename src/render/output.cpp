// The output stage: the only place a StepOutput is written. Force and torque from the graphic/haptic
// difference (paper eqs. 2, 6, 7) with the step's one clamp, against Params::limits; the state and
// depth; the contact summaries; what the stages reported.
#include "render/output.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "render/state_impl.hpp"
#include "render/tunnel.hpp"

namespace cariesim::detail {

namespace {

// Force shading (Morgenbesser and Srinivasan 1996; docs/step.md, "Force shading"). The rows hold the
// tool on the exact sphere pairs (eq. 1), so the coupling force is the rows' reactions Σ λ_i n_i (the
// QP's stationarity, G(d - x_target) = Aᵀλ) and each small inscribed sphere tilts it: a smooth tooth
// felt rough. The rendered force is turned, magnitude kept, from the rigid rows' reaction direction
// (Σ λ_i n_i) to their surface normals' (Σ λ_i n_s,i, shaded_normal), in part where compliant rows
// share the load (by the rigid rows' share of the multipliers), and not where the rows' surface
// normals disagree (a tip between two walls of a fissure: kShadeAgree*): there the load moves between
// walls from one step to the next and a turned force would jump with it. Where the tool goes is the
// sphere pairs' either way.
constexpr double kShadeAgreeFullCos = 0.984807753012208;   // cos 10 degrees
constexpr double kShadeAgreeNoneCos = 0.9396926207859084;  // cos 20 degrees

Vec3 shade_force(const Model& m, const StateImpl& s, const Vec3& force) {
  std::array<Vec3, kQpMaxRows> normals;  // the loaded rigid rows' surface normals, in order
  int loaded = 0;
  Vec3 sphere = Vec3::Zero(), surface = Vec3::Zero();
  double all = 0.0, rigid = 0.0;  // N, the contact rows' multipliers, the rigid rows'
  for (int i = 0; i < s.rows.problem.row_count; ++i) {
    const RowMeta& meta = s.rows.meta[i];
    const double lambda = s.solution.qp.lambda[i];
    if (meta.kind != RowKind::Contact || !(lambda > 0.0)) continue;
    all += lambda;
    if (meta.pair < 0 || meta.region < 0 || s.regions.regions[meta.region].compliant) continue;
    rigid += lambda;
    normals[loaded] = shaded_normal(m, s.pairs, meta.pair);
    sphere += lambda * s.rows.problem.rows[i].a.head<3>();
    surface += lambda * normals[loaded++];
  }
  if (!(rigid > 0.0) || sphere.norm() < 1e-12 || surface.norm() < 1e-12) return force;
  // How well the rigid rows' surface normals agree: the least of them against their mean.
  const Vec3 mean = surface.normalized();
  double least = 1.0;
  for (int k = 0; k < loaded; ++k) least = std::min(least, normals[k].dot(mean));
  const double agree =
      std::clamp((least - kShadeAgreeNoneCos) / (kShadeAgreeFullCos - kShadeAgreeNoneCos), 0.0, 1.0);
  const double weight = agree * rigid / all;
  if (!(weight > 0.0)) return force;
  // The turn that takes the one direction to the other, by `weight` of its angle.
  const Eigen::AngleAxisd full(Quat::FromTwoVectors(sphere.normalized(), mean));
  return Eigen::AngleAxisd(weight * full.angle(), full.axis()) * force;
}

}  // namespace

StepOutput make_output(const Model& m, const Params& p, const StateImpl& s, const Pose& haptic,
                       const StepTrace& trace, std::chrono::steady_clock::time_point start) {
  StepOutput out;
  out.flags = trace.flags;

  // Force and torque: the coupling while sliding (eq. 2; its force shaded), the tunnel's stiffness
  // while penetrating (eq. 6: k_p^t, the device's maximum stiffness; eq. 7: k_θ), bounded by the device.
  const bool inside = penetrating(s.interaction);
  double k_t = p.gains.k_trans, k_r = p.gains.k_rot;
  if (inside) {
    k_t = p.limits.max_stiffness;
    k_r = p.materials[s.tunnel.material].k_theta;
  }
  Vec3 force = k_t * (s.graphic.p - haptic.p);
  Vec3 torque = k_r * rotation_vector(s.graphic.q * haptic.q.conjugate());
  if (!inside && m.settings.force_shading) force = shade_force(m, s, force);
  if (!force.allFinite()) force.setZero();
  if (!torque.allFinite()) torque.setZero();
  // Catching up, and the ramp after it (docs/step.md, "Catching up"): at most the cap.
  if (force.norm() > trace.force_cap) force *= std::max(trace.force_cap, 0.0) / force.norm();
  if (torque.norm() > trace.torque_cap) torque *= std::max(trace.torque_cap, 0.0) / torque.norm();
  if (force.norm() > p.limits.max_force) {
    force *= p.limits.max_force / force.norm();
    out.flags |= kFlagForceClamped;
  }
  if (torque.norm() > p.limits.max_torque) {
    torque *= p.limits.max_torque / torque.norm();
    out.flags |= kFlagTorqueClamped;
  }
  out.force = force;
  out.torque = torque;

  // Poses, state, depth, and what the stages counted.
  out.graphic = s.graphic;
  out.haptic = haptic;
  out.state = s.interaction;
  out.depth = inside ? s.tunnel.depth0 + s.tunnel.depth : 0.0;
  out.lesion = inside ? s.tunnel.lesion : s.tip.lesion;
  out.contacts = trace.contacts;
  out.substeps = trace.substeps;
  out.work = trace.work;
  out.slips = trace.slips;

  // The normal force a force sensor on the tool reads: the rendered force's component along the
  // contacts' net normal (the direction of the sum over contact rows of λ_i n_i). A sum of the rows'
  // magnitudes reported squeezes and the loads of a lagging sub-step's unreached target instead
  // (spikes of 7 N at 0.5 N felt, in a fissure).
  Vec3 net_normal = Vec3::Zero();
  for (int i = 0; i < s.rows.problem.row_count; ++i)
    if (s.rows.meta[i].kind == RowKind::Contact && s.solution.qp.lambda[i] > 0.0)
      net_normal += s.solution.qp.lambda[i] * s.rows.problem.rows[i].a.head<3>();

  // Contact summaries: soft tissue load, the tip's tissue, the strongest contacts.
  for (int r = 0; r < s.regions.count; ++r) {
    const Region& reg = s.regions.regions[r];
    const Material& mat = p.materials[reg.material];
    const double normal_force = s.solution.region_force[r];
    if (mat.tissue == Tissue::Gingiva || mat.tissue == Tissue::Tongue)
      out.soft_tissue_force = std::max(out.soft_tissue_force, normal_force);
    if (reg.tip && (normal_force > 0.0 || reg.gap < 0.0)) out.tip_tissue = static_cast<int>(mat.tissue);
    const ContactReport report{
        s.graphic.transform(reg.tool_point_local) - reg.normal * s.constants.leaf_radius[reg.tool_leaf],
        reg.normal, normal_force, reg.object, reg.tool_leaf};
    if (out.contact_report_count < kMaxReportedContacts) {
      out.contact_reports[out.contact_report_count++] = report;
    } else {
      auto weakest =
          std::min_element(out.contact_reports.begin(), out.contact_reports.end(),
                           [](const ContactReport& a, const ContactReport& b) { return a.force < b.force; });
      if (weakest->force < report.force) *weakest = report;
    }
  }
  const double net = net_normal.norm();
  out.normal_force =
      std::isfinite(net) && net > 0.0 && s.regions.count > 0 ? std::abs(force.dot(net_normal)) / net : 0.0;
  if (inside) out.normal_force = std::abs(force.dot(s.tunnel.n));
  tunnel_spheres(m, s, out.tunnel);

  out.step_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  return out;
}

StepOutput refused_output() {
  StepOutput out;
  out.flags = kFlagWrongState;
  return out;
}

}  // namespace cariesim::detail
