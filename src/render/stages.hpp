#pragma once
// The haptic step as a sequence of stages (docs/design.md §4; docs/step.md draws it). This header
// introduces them: what the step computes, the stages in order with the header each one's
// declarations are in, and what every stage shares. Each stage's header, beside its .cpp, declares
// only what that stage provides.
//
// The math. The graphic tool is the configuration q_g = (p, θ) (tool-frame origin in mm, orientation)
// closest to the haptic tool q_h in the metric G (paper eq. 1): minimise ½ (q_g - q_h)ᵀ G (q_g - q_h)
// subject to the tool's sphere tree not entering the objects' trees. Each cycle linearises that
// around the current graphic configuration g0: a displacement x = (dp, dθ) (mm, rotation vector in
// rad about the tool-frame origin, world axes) moves a tool sphere with lever a = c_t - p by
// dp + dθ × a, so a sphere pair with unit normal n and gap h (mm, negative = overlap) becomes the row
//     n·dp + (a × n)·dθ + c λ >= -h,
// with compliance c = 1/k (mm/N) on tissue of finite stiffness k (c = 0 on rigid tissue). The
// multiplier λ of a row is its contact force in N, so a compliant row is a spring: the tool sinks
// until k·depth balances the coupling. The small dense QP (solver/qp.hpp: 6 variables, dual active
// set, warm-started by row keys) gives x; G is the coupling (eq. 2, F = G(q_g - q_h)) while sliding
// and the tunnel's stiffness (eqs. 6-7) while penetrating.
//
// One sub-step, a sequence of stages with explicit data (each stage's output is the next one's input):
//   collision   (pairs.hpp)        tool tree vs object trees within each leaf's reach -> PairSet: the
//                                  sphere pairs with their geometry at g0, measured once
//   regions     (regions.hpp)      pairs grouped per object and nearby tool point, deepest first ->
//                                  RegionSet: the unit of compliance and friction
//   anchors     (friction.hpp)     each sticking anchor meets its region of this solve and is laid into
//                                  its tangent plane (the only place an anchor moves before a solve)
//   rows        (rows.hpp: RowSet and the key spaces) one builder per row kind, each owning its
//               warm-start key space -> RowSet:
//                 contact_rows.hpp  non-penetration rows (eq. 1's constraint; compliant rows regularised)
//                 friction.hpp      two tangent equality rows per sticking anchor (§3.2, Figs. 10-11)
//                 tunnel.hpp        the virtual tunnel's rows (Fig. 5, eqs. 6-9)
//   solve       (solve.hpp)        the QP -> Solution: displacement, multipliers, per-region normal
//                                  force, and every QP status that is not Optimal as a StepFlag; the
//                                  pairs whose rows bore load are carried to the next solve
//   slip        (friction.hpp)     once per sub-step, after the final solve: the Coulomb cone decides
//                                  which anchors stick, slip (moved onto the dynamic cone) or release
//                                  -> SlipPlan, applied between two solves; then the rows are solved again
//   re-check    (pairs.hpp)        collision at the solution: a rigid overlap adds its pair (measured at
//                                  g0 like every other) and the sub-step is solved again; what remains
//                                  is backtracked (substep.hpp)
// The sub-step (substep.hpp) runs these stages in order.
// One cycle (step.cpp): check the input; the state machine (paper Fig. 4) runs the sliding state
// (sub-steps of bounded motion until the hand is reached, docs/design.md §4 step 3; new anchors; what
// the tip touches) or the penetration state (tunnel.hpp: eqs. 3-5 and 8-9 move the tunnel's bottom,
// one sub-step with the tunnel's rows and the additional contacts of Fig. 7); then the output stage
// (output.hpp) fills the StepOutput, the only place that writes it, with the one force clamp.
//
// Data that lives longer than a stage: StateImpl (state_impl.hpp) holds the history (graphic pose,
// interaction state, tunnel, anchors, tip contact) and every stage's output, reserved once.

#include <cstdint>
#include <limits>
#include <vector>

#include "cariesim/render/step.hpp"

namespace cariesim::detail {

// What every stage shares: the capacities of the stages' outputs, the constants the model gives the
// step, the arithmetic of a displacement, and the trace the stages report through.

inline constexpr int kMaxAnchors = 8;         ///< simultaneously sticking contact regions
inline constexpr int kMaxRegions = 32;        ///< contact regions per solve
inline constexpr int kMaxPairs = 512;         ///< sphere pairs kept for the rows of one sub-step
inline constexpr double kRegionRadius = 1.0;  ///< mm: tool leaves this close share a contact region

/// What the step derives from the Model once, when a State is created.
struct ModelConstants {
  std::size_t object_count = 0;
  std::size_t tool_leaves = 0;
  ObjectMask all_mask = 0;
  ObjectMask rigid_mask = 0;        ///< objects whose every leaf is of rigid material
  std::vector<Vec3> leaf_local;     ///< mm, tool leaf centres in the tool frame
  std::vector<double> leaf_radius;  ///< mm
  double max_reach = 0.0;           ///< mm, the largest |leaf centre| (lever length)
};

/// 6-D difference (translation mm, rotation vector rad) that moves `from` onto `to` (substep.cpp).
Vec6 config_difference(const Pose& to, const Pose& from);
/// `g` moved by a 6-D displacement (rotation about the tool-frame origin, world axes; substep.cpp).
Pose apply_displacement(const Pose& g, const Vec6& d);

/// What the stages of one cycle report, turned into the StepOutput by the output stage.
struct StepTrace {
  uint32_t flags = 0;  ///< StepFlag bits
  int contacts = 0;    ///< contact rows in the final solve
  int substeps = 0;    ///< sub-steps taken
  int slips = 0;       ///< anchors that slipped
  int64_t work = 0;    ///< node pairs the collision queries visited
  /// N and N·mm: the most force and torque rendered while catching up (0) and while they ramp in after
  /// it (kCatchUpRamp); +infinity otherwise
  double force_cap = std::numeric_limits<double>::infinity();
  double torque_cap = std::numeric_limits<double>::infinity();
};

}  // namespace cariesim::detail
