#pragma once
// The sub-step (substep.cpp): one bounded optimisation of the graphic tool, the stages of stages.hpp in
// order (paper eq. 1 linearised; docs/design.md §4 steps 1-4).

#include <cstdint>

#include "render/stages.hpp"

namespace cariesim::detail {

struct TunnelLimits;  // tunnel.hpp
struct Engagement;    // tunnel.hpp

/// Work units (WorkBudget) of one solve: regions, anchors, rows and the QP (about 3.3 us against 12 ns
/// a node pair, fitted on step_bench's trajectories).
inline constexpr int64_t kSolveWork = 280;

/// One sub-step's request.
struct SubstepRequest {
  Vec6 target = Vec6::Zero();  ///< 6-D displacement toward which the graphic tool is pulled
  Mat6 G = Mat6::Identity();   ///< weights of the distance (N/mm, N·mm/rad)
  double trans_bound = 0.0;    ///< mm, largest tool-origin motion of this sub-step (trust region)
  double rot_bound = 0.0;      ///< rad, largest rotation of this sub-step
  ObjectMask mask = kAllObjects;
  bool friction = true;                  ///< anchors, stick rows and the cone
  bool hold_only = false;                ///< see build_contact_rows
  const TunnelLimits* tunnel = nullptr;  ///< the tunnel's rows, when penetrating
  const Engagement* engaged = nullptr;   ///< the engaged tip's lateral rows, when sliding engaged
};
/// A sub-step's first solve's motion before it was shortened onto the bounds.
struct SubstepMotion {
  double trans = 0.0;  ///< mm
  double rot = 0.0;    ///< rad
};
/// Solves one sub-step from g0 (paper eq. 1 linearised: docs/design.md §4 steps 1-4): the graphic tool
/// is pulled toward the full target but moves at most by the bounds (the solution is shortened onto
/// them; every pair within reach of that motion is in the rows). Sets `reached` when the solution
/// was within the bounds (the last sub-step of a cycle; the friction cone is checked then, and by
/// sliding_step after a cycle none of whose sub-steps reached).
/// Never leaves the tool overlapping rigid tissue by more than the tolerance when g0 did not:
/// re-checks collision at the solution, re-solves with new pairs, backtracks if needed. With
/// `wanted`, reports what the first solve asked for (sliding_step carries it to the next cycle when
/// this one ends lagging).
Pose solve_substep(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                   StepTrace& trace, bool& reached, SubstepMotion* wanted = nullptr);
/// The friction cone on the last solve, made at g0 with coupling G (paper §3.2): slipping anchors
/// move, unloaded ones release (counted in trace.slips). True when any anchor changed.
bool slip_anchors(const Params& p, StateImpl& s, const Pose& g0, const Mat6& G, StepTrace& trace);

}  // namespace cariesim::detail
