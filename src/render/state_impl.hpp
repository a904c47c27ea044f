#pragma once
// Private state of the haptic step: what carries over between cycles (graphic pose, interaction
// state, virtual tunnel, friction anchors, the tip's last contact), what the step derives from the
// Model, and every stage's output (the stages' headers, introduced by stages.hpp), reserved when the
// state is created so that the step itself never allocates.

#include <cstdint>

#include "cariesim/device/input_guard.hpp"
#include "cariesim/solver/qp.hpp"
#include "render/contact_rows.hpp"
#include "render/friction.hpp"
#include "render/pairs.hpp"
#include "render/regions.hpp"
#include "render/rows.hpp"
#include "render/solve.hpp"
#include "render/stages.hpp"
#include "render/tunnel.hpp"

namespace cariesim {

/// The caries the tip sank into at the end of the last cycle (the penetration criteria read it).
struct TipContact {
  int16_t lesion = -1;    ///< lesion whose caries the tip touched, -1 for none
  uint16_t material = 0;  ///< that caries' material
  double sink = 0.0;      ///< mm, how deep the tip was in it
};

struct StateImpl {
  explicit StateImpl(const Model& model);

  // History.
  Pose graphic;
  InputGuard input;  ///< judges each reading (device/input_guard.hpp); holds the haptic pose used last
  InteractionState interaction = InteractionState::Free;
  detail::Tunnel tunnel;
  detail::Engagement engaged;  ///< the tip caught on caries before breaking in (tunnel.hpp)
  detail::Anchors anchors{};
  TipContact tip;
  uint64_t steps = 0;
  double last_motion = 0.0;    ///< mm, tool-origin translation of the graphic tool in the last cycle
  double last_rotation = 0.0;  ///< rad, its rotation in the last cycle
  /// When the last cycle ended lagging, the motion its last sub-step's solve asked for before it was
  /// shortened onto the bounds (mm, rad; zero otherwise): the next cycle's first bounds start there.
  double lag_motion = 0.0;
  double lag_rotation = 0.0;
  detail::CarriedPairs carried;  ///< pairs that bore load at the last solve (CarriedPairs)
  /// The force and torque rendered are capped at this share, 0-1, of the device's maximum: zero when
  /// the state started the tool away from the hand (the start was not clear), then rising to 1 over
  /// kCatchUpRamp.
  double force_ramp = 1.0;

  // Model-derived constants.
  detail::ModelConstants constants;

  // Stage outputs and scratch (reserved once), in stage order.
  detail::CollisionScratch collision;
  detail::PairSet pairs;
  detail::RegionSet regions;
  detail::ContactRowScratch contact_rows;
  detail::RowSet rows;
  detail::Solution solution;
  detail::SlipPlan slips;
  QpSolver solver;
};

/// The render module's access to a State's private part: the step (step.cpp) and the render tests.
/// Nothing outside render reaches it; the public State (cariesim/render/step.hpp) names no accessor.
struct StateAccess {
  static StateImpl& of(State& state) { return *state.impl_; }
  static const StateImpl& of(const State& state) { return *state.impl_; }
};

/// The private part of `state`.
inline StateImpl& state_impl(State& state) { return StateAccess::of(state); }
/// The private part of `state`, read only.
inline const StateImpl& state_impl(const State& state) { return StateAccess::of(state); }

}  // namespace cariesim
