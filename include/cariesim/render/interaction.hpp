#pragma once
/// What the haptic step reports in codes, on its own so that whoever stores or compares them (the
/// record, the experiments, the scores) needs nothing else of the step: the interaction state (paper
/// Fig. 4) and the output flags (StepOutput::state and StepOutput::flags, render/step.hpp).

#include <cstdint>

namespace cariesim {

/// Interaction state (paper Fig. 4). The codes are stored (docs/records.md, `state_names`).
enum class InteractionState : uint8_t { Free, Sliding, Inserting, Extracting };

/// "free", "sliding", "inserting" or "extracting".
constexpr const char* state_name(InteractionState s) {
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

/// True in the penetration state (inserting or extracting): the tip is inside a lesion, held by the
/// virtual tunnel (paper Fig. 5, docs/penetration.md).
constexpr bool penetrating(InteractionState s) {
  return s == InteractionState::Inserting || s == InteractionState::Extracting;
}

/// s: when a run starts with the hand where the tool cannot be (inside an object), the tool starts at
/// the home pose and the most force (torque) rendered rises from zero to the device's maximum over
/// this time, so that a hand found deep in an object is not struck with the whole coupling force.
inline constexpr double kCatchUpRamp = 0.2;

/// Output flags (StepOutput::flags).
enum StepFlag : uint32_t {
  kFlagNonFiniteInput = 1u << 0,     ///< the haptic pose was NaN/inf or not a unit quaternion; the
                                     ///< last good one was used (kInputNonFinite)
  kFlagJumpLimited = 1u << 1,        ///< the haptic tool moved (turned) further than max_jump
                                     ///< (max_jump_rotation) in one step (kInputJump)
  kFlagInfeasible = 1u << 2,         ///< the constraints contradicted each other; the tool held still
  kFlagContactOverflow = 1u << 3,    ///< more sphere pairs than the contact capacity
  kFlagForceClamped = 1u << 4,       ///< force limited to the device maximum
  kFlagTorqueClamped = 1u << 5,      ///< torque limited to the device maximum
  kFlagLagging = 1u << 6,            ///< sub-step budget exhausted; the graphic tool is catching up
  kFlagQpRowsFull = 1u << 7,         ///< more constraint rows than the QP capacity
  kFlagBacktracked = 1u << 8,        ///< the solution overlapped rigid tissue and was shortened
  kFlagWrongState = 1u << 9,         ///< the state or params were made for another model; nothing was done
  kFlagQpActiveSetFull = 1u << 10,   ///< more rows wanted to be active than the QP holds; last iterate used
  kFlagQpIterationLimit = 1u << 11,  ///< the QP ran out of dual steps; its last iterate was used
  kFlagWorkBudget = 1u << 12,        ///< the step's collision work budget ran out (StepSettings::work_budget)
  /// Free, but the graphic tool is still on its way to the hand (it started away from it, e.g. the
  /// hand began inside a tooth, or an object held it while the hand passed through): the force is the
  /// coupling's pull toward it, no contact (docs/step.md, "Catching up")
  kFlagCatchingUp = 1u << 13,
};

}  // namespace cariesim
