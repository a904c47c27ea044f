// The haptic step (docs/design.md §4; the stages are described in stages.hpp): check the input, run the
// sliding or penetration state for one cycle (paper Fig. 4), and hand everything to the output stage.
#include "cariesim/render/step.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <string>

#include "cariesim/common/error.hpp"
#include "render/output.hpp"
#include "render/state_impl.hpp"
#include "render/substep.hpp"
#include "render/tunnel.hpp"

namespace cariesim {

using namespace detail;

namespace {

// Model-derived constants: masks, tool leaves. The overlap re-check's rigid objects are the model's
// (rigid_objects, render/model.hpp).
ModelConstants constants_of(const Model& model) {
  ModelConstants k;
  k.object_count = model.objects.size();
  if (k.object_count > 64)
    throw Error("model has " + std::to_string(k.object_count) + " objects; at most 64");
  k.tool_leaves = model.tool.tree.leaf_count();
  if (k.tool_leaves == 0) throw Error("model has an empty tool tree");
  for (std::size_t i = 0; i < k.object_count; ++i) k.all_mask |= ObjectMask{1} << i;
  k.rigid_mask = rigid_objects(model);
  k.leaf_local.resize(k.tool_leaves);
  k.leaf_radius.resize(k.tool_leaves);
  for (std::size_t i = 0; i < k.tool_leaves; ++i) {
    const SphereNode& node = model.tool.tree.nodes[model.tool.tree.leaf_nodes[i]];
    k.leaf_local[i] = node.center.cast<double>();
    k.leaf_radius[i] = node.radius;
    k.max_reach = std::max(k.max_reach, k.leaf_local[i].norm());
  }
  return k;
}

}  // namespace

// Model-derived constants and every stage's scratch, reserved once.
StateImpl::StateImpl(const Model& model)
    : constants(constants_of(model)), collision(model), contact_rows(constants) {}

State::State(const Model& model, const Pose& start) : impl_(std::make_unique<StateImpl>(model)) {
  // Start where asked when that pose is clear of every object, else at the model's home pose.
  StateImpl& s = *impl_;
  Pose pose = start;
  bool clear = pose.finite();
  if (clear) {
    s.collision.placed.place(pose, 0.0);
    clear = !(closest(s.collision.placed, model.objects, s.constants.all_mask, 0.0).gap < 0.0);
  }
  s.graphic = clear ? pose : model.tool_home;
  s.force_ramp = clear ? 1.0 : 0.0;  // placed away from the hand: the force ramps in (docs/step.md)
  s.input = InputGuard(model.settings.input, s.graphic);
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
  return impl_->constants.object_count == model.objects.size() &&
         impl_->constants.tool_leaves == model.tool.tree.leaf_count();
}
int State::collected_pairs() const { return impl_->pairs.count; }

namespace detail {

// The sliding state, a stage of the cycle used only here:
// the sliding state for one cycle (paper §3.2): bounded sub-steps toward the haptic tool, friction on
// caries, then new anchors and what the tip touches;
void sliding_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, StepTrace& trace);
// what the tool touches at g after the sub-steps: whether anything (sliding rather than free), and
// the caries the tip sank into and how deep (the penetration criteria of the next cycle).
bool sense_tip(const Model& m, const Params& p, StateImpl& s, const Pose& g);

void sliding_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, StepTrace& trace) {
  const Vec6 remaining = config_difference(haptic, s.graphic);
  const double trans = remaining.head<3>().norm();
  const double rot = remaining.tail<3>().norm();

  // Free space: nothing within reach of the whole motion, so the graphic tool follows the hand. In
  // contact a pair of the last collection usually shows it is not, without searching the trees.
  const double reach = trans + rot * s.constants.max_reach + m.settings.contact_margin;
  bool free = false;
  if (!listed_within(m, s.constants, s.collision, s.graphic, reach)) {
    s.collision.placed.place(s.graphic, 0.0);
    const ClosestPair near =
        any_within(s.collision.placed, m.objects, s.constants.all_mask, reach, &s.collision.budget);
    free = near.complete && !std::isfinite(near.gap);
  }
  if (free) {
    s.graphic = haptic;
    s.lag_motion = s.lag_rotation = 0.0;
    s.regions.count = 0;
    s.carried.count = 0;
    release_anchors(s.anchors);
    s.tip.lesion = -1;
    s.interaction = InteractionState::Free;
    return;
  }

  // Trust region: sub-steps of bounded motion, each pulled toward the haptic tool, until one ends
  // inside its bounds. In steady contact that is the first one. G is the coupling of eq. 2.
  SubstepRequest req;
  req.G.setZero();
  req.G.diagonal() << p.gains.k_trans, p.gains.k_trans, p.gains.k_trans, p.gains.k_rot, p.gains.k_rot,
      p.gains.k_rot;
  // The first bound follows the last cycle's motion (a resting or slowly sliding tool needs only a
  // thin collision margin), or what the last cycle still wanted when it ended lagging (a short
  // cycle cut by its share of the work budget would otherwise restart from a small bound and
  // fall further behind); each further sub-step doubles it up to the trust region.
  req.trans_bound =
      std::clamp(std::max(2.0 * s.last_motion + 0.005, s.lag_motion), 0.01, m.settings.trust_step);
  req.rot_bound =
      std::clamp(std::max(2.0 * s.last_rotation + 1e-4, s.lag_rotation), 1e-3, m.settings.trust_rotation);
  // A tip pressed on caries catches (docs/penetration.md "Engagement"): it holds its place sideways,
  // its lateral rows standing in for the friction rows.
  if (update_engagement(p, s, haptic)) {
    release_anchors(s.anchors);
    req.friction = false;
    req.engaged = &s.engaged;
  }
  Pose g = s.graphic, g0 = s.graphic;  // g0: where the last sub-step started (its solve's configuration)
  bool reached = false;
  int k = 0;
  // The work budget ends the sub-steps early: the first always runs (held where it is clear when the
  // budget runs out inside it); a further one starts only while what is left of the cycle's share of
  // the budget (substep_budget: all of it at 1 kHz and below) covers the costliest
  // sub-step so far, so that the step's time stays bounded. The share is at most
  // the budget, so this also keeps the step within the budget itself.
  int64_t costliest = 0;
  WorkBudget& budget = s.collision.budget;
  while (!reached && k < std::max(1, m.settings.max_substeps)) {
    if (k > 0 && (budget.spent() || s.collision.substep_budget - budget.used < costliest)) {
      trace.flags |= kFlagWorkBudget;
      break;
    }
    const int64_t before = budget.used;
    req.target = config_difference(haptic, g);
    g0 = g;
    SubstepMotion wanted;
    g = solve_substep(m, p, s, g, req, trace, reached, &wanted);
    s.lag_motion = reached ? 0.0 : wanted.trans;
    s.lag_rotation = reached ? 0.0 : wanted.rot;
    costliest = std::max(costliest, budget.used - before);
    req.trans_bound = std::min(2.0 * req.trans_bound, m.settings.trust_step);
    req.rot_bound = std::min(2.0 * req.rot_bound, m.settings.trust_rotation);
    ++k;
  }
  if (!reached) {
    trace.flags |= kFlagLagging;
    // The friction cone (paper §3.2, Figs. 10-11) is decided once the motion ends in a sub-step
    // (solve_substep). A tool that lags behind the hand in every sub-step of every cycle would
    // otherwise never let go of its anchors however hard the hand pulls (docs/performance.md: pinned in
    // 46's fossa for 3 s at up to 2.9 N): the cone is also decided on the cycle's last solve, at its
    // configuration g0, and the next cycle starts from what it decided.
    slip_anchors(p, s, g0, req.G, trace);
  }
  s.graphic = g;
  trace.substeps = k;

  // New sticking contacts, and what the tip touches (for the penetration criteria next cycle).
  create_anchors(p, s.regions, s.solution, g, s.anchors);
  s.interaction = sense_tip(m, p, s, g) ? InteractionState::Sliding : InteractionState::Free;
  // Touching nothing but still short of the hand: the tool is catching up in free space (it started
  // away from the hand, or the hand passed through what held it); the force is the coupling's pull.
  if (s.interaction == InteractionState::Free && !reached) trace.flags |= kFlagCatchingUp;
}

bool sense_tip(const Model& m, const Params& p, StateImpl& s, const Pose& g) {
  s.tip.lesion = -1;
  bool touching = false;
  for (int r = 0; r < s.regions.count; ++r) {
    // Touching: the region's founding pair is within the contact margin at g, or it carries load.
    const Region& reg = s.regions.regions[r];
    const PairGeometry geo = measure_pair(m, s.constants, g, s.pairs.refs[reg.pair]);
    touching = touching || geo.gap <= m.settings.contact_margin || s.solution.region_force[r] > 0.0;
    const Material& mat = p.materials[reg.material];
    if (!(reg.tip && mat.tissue == Tissue::Caries && mat.lesion >= 0 && geo.gap < 0.0)) continue;
    // How deep the tip is in the caries: the shallowest penetration among the region's surface
    // patches (as for its rows), not the deepest pair, which may measure from a far side face.
    double sink = -geo.gap;
    for (int i = 0; i < s.regions.pairs; ++i) {
      if (s.regions.pair_region[i] != r) continue;
      const PairGeometry pg = measure_pair(m, s.constants, g, s.pairs.refs[i]);
      if (pg.gap < 0.0 && std::isfinite(pg.lateral) && !pg.wall) sink = std::min(sink, -pg.gap);
    }
    if (s.tip.lesion < 0 || sink > s.tip.sink) {
      s.tip.lesion = mat.lesion;
      s.tip.material = reg.material;
      s.tip.sink = sink;
    }
  }
  return touching;
}

}  // namespace detail

StepOutput step(const Model& m, const Params& p, State& state, const HapticInput& in) {
  const auto start = std::chrono::steady_clock::now();
  assert(state.built_for(m) && "state built for another model");
  assert(p.materials.size() == m.defaults.materials.size() && "params made for another model");
  if (!state.built_for(m) || p.materials.size() != m.defaults.materials.size()) return refused_output();
  StateImpl& s = state_impl(state);
  StepTrace trace;
  s.collision.budget = WorkBudget{std::max<int64_t>(m.settings.work_budget, 0), 0};

  // The input guard (device/input_guard.hpp) judges the reading: an invalid or unusable pose reuses
  // the last good one; a jump beyond max_jump, or a turn beyond max_jump_rotation, is flagged (the
  // sub-step budget then limits how far the graphic tool follows in this cycle).
  const uint32_t input_faults = s.input.judge(in.pose, in.valid, in.age);
  if ((input_faults & kInputNonFinite) != 0) trace.flags |= kFlagNonFiniteInput;
  if ((input_faults & kInputJump) != 0) trace.flags |= kFlagJumpLimited;
  const Pose haptic = s.input.pose();
  const double dt = std::isfinite(in.dt) && in.dt > 0.0 && in.dt <= 0.1 ? in.dt : 1.0 / m.servo_rate;
  // The budget is per kWorkBudgetCycle of simulated time: a shorter cycle lets further sub-steps use
  // its share of it, so the work per second stays the same at any rate. The first sub-step keeps the
  // whole budget, so a heavy contact never holds the tool for want of it.
  s.collision.substep_budget = static_cast<int64_t>(static_cast<double>(s.collision.budget.left) *
                                                    std::min(1.0, dt / kWorkBudgetCycle));

  // The interaction state machine (paper Fig. 4).
  const Pose graphic_before = s.graphic;
  bool inside = penetrating(s.interaction);
  if (!inside) inside = try_enter_penetration(m, p, s, haptic);
  if (inside) {
    penetration_step(m, p, s, haptic, dt, trace);
    s.lag_motion = s.lag_rotation = 0.0;
  } else {
    sliding_step(m, p, s, haptic, trace);
  }

  // History for the next cycle, then the output stage.
  const Vec6 moved = config_difference(s.graphic, graphic_before);
  s.last_motion = moved.head<3>().norm();
  s.last_rotation = moved.tail<3>().norm();
  ++s.steps;
  // After a start away from the hand the force ramps in over kCatchUpRamp (docs/step.md, "Catching
  // up"): a hand found deep inside a tooth is not struck with the whole coupling at once.
  s.force_ramp = std::min(1.0, s.force_ramp + dt / kCatchUpRamp);
  if (s.force_ramp < 1.0) {
    trace.force_cap = s.force_ramp * p.limits.max_force;
    trace.torque_cap = s.force_ramp * p.limits.max_torque;
  }
  trace.work = s.collision.budget.used;
  if (s.collision.budget.spent()) trace.flags |= kFlagWorkBudget;
  StepOutput out = make_output(m, p, s, haptic, trace, start);
  out.input_faults = input_faults;
  return out;
}

StepOutput step(const Model& m, State& state, const HapticInput& in) {
  return step(m, m.defaults, state, in);
}

}  // namespace cariesim
