// The haptic step (DESIGN.md §4): sanitise the input, run the sliding or penetration state for one
// cycle, and turn the graphic/haptic difference into a bounded force and torque.
#include "cariesim/render/step.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>

#include "cariesim/common/error.hpp"
#include "render/internal.hpp"

namespace cariesim {

using namespace detail;

const char* state_name(InteractionState s) {
  switch (s) {
    case InteractionState::Free:
      return "free";
    case InteractionState::Sliding:
      return "sliding";
    case InteractionState::Inserting:
      return "inserting";
    case InteractionState::Extracting:
      return "extracting";
  }
  return "free";
}

// Model-derived constants and scratch memory, reserved once.
StateImpl::StateImpl(const Model& model) : placed(model.tool.tree), contacts(model.capacities.contacts) {
  object_count = model.objects.size();
  if (object_count > 64) throw Error("model has " + std::to_string(object_count) + " objects; at most 64");
  tool_leaves = model.tool.tree.leaf_count();
  if (tool_leaves == 0) throw Error("model has an empty tool tree");
  // An object counts as rigid for the overlap re-check when every one of its leaves is of rigid
  // material (its kind only says how it is drawn).
  for (std::size_t i = 0; i < object_count; ++i) {
    all_mask |= ObjectMask{1} << i;
    const SphereTree& tree = model.objects[i].tree;
    const bool rigid = std::all_of(tree.leaf_nodes.begin(), tree.leaf_nodes.end(), [&](uint32_t node) {
      const uint16_t material = tree.nodes[node].material;
      return material < model.defaults.materials.size() && model.defaults.materials[material].rigid();
    });
    if (rigid && !tree.empty()) rigid_mask |= ObjectMask{1} << i;
  }
  leaf_local.resize(tool_leaves);
  leaf_radius.resize(tool_leaves);
  leaf_reach.resize(tool_leaves);
  leaf_margin.resize(tool_leaves);
  leaf_rows.resize(2 * tool_leaves);
  contact_order.resize(model.capacities.contacts);
  contact_rank.resize(model.capacities.contacts);
  for (std::size_t i = 0; i < tool_leaves; ++i) {
    const SphereNode& node = model.tool.tree.nodes[model.tool.tree.leaf_nodes[i]];
    leaf_local[i] = node.center.cast<double>();
    leaf_radius[i] = node.radius;
    leaf_reach[i] = leaf_local[i].norm();
    max_reach = std::max(max_reach, leaf_reach[i]);
  }
}

State::State(const Model& model, const Pose& start) : impl_(std::make_unique<StateImpl>(model)) {
  // Start where asked when that pose is clear of every object, else at the model's home pose.
  StateImpl& s = *impl_;
  Pose pose = start;
  bool clear = pose.finite();
  if (clear) {
    s.placed.place(pose, 0.0);
    clear = !(closest(s.placed, model.objects, s.all_mask, 0.0).gap < 0.0);
  }
  s.graphic = clear ? pose : model.tool_home;
  s.last_haptic = s.graphic;
}

State::~State() = default;
State::State(State&&) noexcept = default;
State& State::operator=(State&&) noexcept = default;
const Pose& State::graphic() const { return impl_->graphic; }
InteractionState State::interaction() const { return impl_->interaction; }
double State::depth() const {
  return impl_->tunnel.lesion >= 0 ? impl_->tunnel.depth0 + impl_->tunnel.depth : 0.0;
}
bool State::built_for(const Model& model) const {
  return impl_->object_count == model.objects.size() && impl_->tool_leaves == model.tool.tree.leaf_count();
}

namespace {

// The sliding state (paper §3.2): bounded sub-steps toward the haptic tool, friction on caries.
void sliding_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, StepOutput& out) {
  Vec6 remaining = config_difference(haptic, s.graphic);
  const double trans = remaining.head<3>().norm();
  const double rot = remaining.tail<3>().norm();

  // Free space: nothing within reach of the whole motion, so the graphic tool follows the hand.
  s.placed.place(s.graphic, 0.0);
  const double reach = trans + rot * s.max_reach + m.settings.contact_margin;
  if (!std::isfinite(closest(s.placed, m.objects, s.all_mask, reach).gap)) {
    s.graphic = haptic;
    s.region_count = 0;
    s.problem.row_count = 0;
    release_anchors(s);
    s.tip_lesion = -1;
    s.interaction = InteractionState::Free;
    return;
  }

  // Trust region: sub-steps of bounded motion, each pulled toward the haptic tool, until one ends
  // inside its bounds. In steady contact that is the first one.
  SubstepRequest req;
  req.G.setZero();
  req.G.diagonal() << p.gains.k_trans, p.gains.k_trans, p.gains.k_trans, p.gains.k_rot, p.gains.k_rot,
      p.gains.k_rot;
  // The first bound follows the last cycle's motion (a resting or slowly sliding tool needs only a
  // thin collision margin); each further sub-step doubles it up to the trust region.
  req.trans_bound = std::clamp(2.0 * s.last_motion + 0.005, 0.01, m.settings.trust_step);
  req.rot_bound = std::clamp(2.0 * s.last_rotation + 1e-4, 1e-3, m.settings.trust_rotation);
  Pose g = s.graphic;
  bool reached = false;
  int k = 0;
  while (!reached && k < std::max(1, m.settings.max_substeps)) {
    req.target = config_difference(haptic, g);
    g = solve_substep(m, p, s, g, req, out, reached);
    req.trans_bound = std::min(2.0 * req.trans_bound, m.settings.trust_step);
    req.rot_bound = std::min(2.0 * req.rot_bound, m.settings.trust_rotation);
    ++k;
  }
  if (!reached) out.flags |= kFlagLagging;
  s.graphic = g;
  out.substeps = k;

  // New sticking contacts, and what the tip touches (for the penetration criteria next cycle).
  create_anchors(p, s, g);
  s.tip_lesion = -1;
  bool touching = false;
  for (int r = 0; r < s.region_count; ++r) {
    const Region& reg = s.regions[r];
    const PairGeometry geo = pair_geometry(m, s, g, s.pairs[reg.pair]);
    touching = touching || geo.gap <= m.settings.contact_margin || reg.normal_force > 0.0;
    const Material& mat = p.materials[reg.material];
    if (!(reg.tip && mat.tissue == Tissue::Caries && mat.lesion >= 0 && geo.gap < 0.0)) continue;
    // How deep the tip is in the caries: the shallowest penetration among the region's surface
    // patches (as for its rows), not the deepest pair, which may measure from a far side face.
    double sink = -geo.gap;
    for (int i = 0; i < s.pair_count; ++i) {
      if (s.pair_region[i] != r) continue;
      const PairGeometry pg = pair_geometry(m, s, g, s.pairs[i]);
      if (pg.gap < 0.0 && std::isfinite(pg.lateral) && !pg.wall) sink = std::min(sink, -pg.gap);
    }
    if (s.tip_lesion < 0 || sink > s.tip_sink) {
      s.tip_lesion = mat.lesion;
      s.tip_material = reg.material;
      s.tip_sink = sink;
    }
  }
  s.interaction = touching ? InteractionState::Sliding : InteractionState::Free;
}

// Force and torque from the graphic/haptic difference (paper eqs. 2, 6, 7), bounded by the device.
void finish_output(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, StepOutput& out) {
  const bool inside =
      s.interaction == InteractionState::Inserting || s.interaction == InteractionState::Extracting;
  double k_t = p.gains.k_trans, k_r = p.gains.k_rot;
  if (inside) {
    k_t = p.limits.max_stiffness;                  // eq. 6: k_p^t, the device's maximum stiffness
    k_r = p.materials[s.tunnel.material].k_theta;  // eq. 7
  }
  Vec3 force = k_t * (s.graphic.p - haptic.p);
  Vec3 torque = k_r * rotation_vector(s.graphic.q * haptic.q.conjugate());
  if (!force.allFinite()) force.setZero();
  if (!torque.allFinite()) torque.setZero();
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
  out.graphic = s.graphic;
  out.haptic = haptic;
  out.state = s.interaction;
  out.depth = inside ? s.tunnel.depth0 + s.tunnel.depth : 0.0;
  out.lesion = inside ? s.tunnel.lesion : s.tip_lesion;

  // Contact summaries: total normal force, soft tissue load, the tip's tissue, the strongest contacts.
  out.normal_force = 0.0;
  out.soft_tissue_force = 0.0;
  out.tip_tissue = -1;
  out.contact_report_count = 0;
  for (int r = 0; r < s.region_count; ++r) {
    const Region& reg = s.regions[r];
    const Material& mat = p.materials[reg.material];
    out.normal_force += reg.normal_force;
    if (mat.tissue == Tissue::Gingiva || mat.tissue == Tissue::Tongue)
      out.soft_tissue_force = std::max(out.soft_tissue_force, reg.normal_force);
    if (reg.tip && (reg.normal_force > 0.0 || reg.gap < 0.0)) out.tip_tissue = static_cast<int>(mat.tissue);
    ContactReport report{
        s.graphic.transform(reg.tool_point_local) - reg.normal * s.leaf_radius[reg.tool_leaf], reg.normal,
        reg.normal_force, reg.object, reg.tool_leaf};
    if (out.contact_report_count < kMaxReportedContacts) {
      out.contact_reports[out.contact_report_count++] = report;
    } else {
      auto weakest =
          std::min_element(out.contact_reports.begin(), out.contact_reports.end(),
                           [](const ContactReport& a, const ContactReport& b) { return a.force < b.force; });
      if (weakest->force < report.force) *weakest = report;
    }
  }
  if (inside) out.normal_force = std::abs(force.dot(s.tunnel.n));
  tunnel_spheres(m, s, out.tunnel);
}

}  // namespace

StepOutput step(const Model& m, const Params& p, State& state, const HapticInput& in) {
  const auto start = std::chrono::steady_clock::now();
  StepOutput out;
  assert(state.built_for(m) && "state built for another model");
  assert(p.materials.size() == m.defaults.materials.size() && "params made for another model");
  if (!state.built_for(m) || p.materials.size() != m.defaults.materials.size()) {
    out.flags |= kFlagWrongState;
    return out;
  }
  StateImpl& s = state.impl();

  // Input checks: a non-finite pose reuses the last good one; a jump beyond max_jump is flagged (the
  // sub-step budget then limits how far the graphic tool follows in this cycle).
  Pose haptic = in.pose;
  if (!(haptic.p.allFinite() && haptic.q.coeffs().allFinite() && haptic.q.norm() > 0.5)) {
    out.flags |= kFlagNonFiniteInput;
    haptic = s.have_haptic ? s.last_haptic : s.graphic;
  }
  haptic.q.normalize();
  const double dt = std::isfinite(in.dt) && in.dt > 0.0 && in.dt <= 0.1 ? in.dt : 1.0 / m.servo_rate;
  if (s.have_haptic && (haptic.p - s.last_haptic.p).norm() > m.settings.max_jump)
    out.flags |= kFlagJumpLimited;

  const Pose graphic_before = s.graphic;

  // The interaction state machine (paper Fig. 4).
  bool inside = s.interaction == InteractionState::Inserting || s.interaction == InteractionState::Extracting;
  if (!inside) inside = try_enter_penetration(m, p, s, haptic);
  if (inside)
    penetration_step(m, p, s, haptic, dt, out);
  else
    sliding_step(m, p, s, haptic, out);

  const Vec6 moved = config_difference(s.graphic, graphic_before);
  s.last_motion = moved.head<3>().norm();
  s.last_rotation = moved.tail<3>().norm();
  s.last_haptic = haptic;
  s.have_haptic = true;
  ++s.steps;
  finish_output(m, p, s, haptic, out);
  out.step_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  return out;
}

StepOutput step(const Model& m, State& state, const HapticInput& in) {
  return step(m, m.defaults, state, in);
}

}  // namespace cariesim
