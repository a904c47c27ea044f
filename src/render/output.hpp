#pragma once
// The output stage (output.cpp), the only writer of a StepOutput.

#include <chrono>

#include "render/stages.hpp"

namespace cariesim::detail {

/// Force and torque from the graphic/haptic difference (eqs. 2, 6, 7) clamped to Params::limits, the
/// state, the contact summaries and the trace; step_us from `start` to now.
StepOutput make_output(const Model& m, const Params& p, const StateImpl& s, const Pose& haptic,
                       const StepTrace& trace, std::chrono::steady_clock::time_point start);
/// The output of a step refused because the state or params were made for another model.
StepOutput refused_output();

}  // namespace cariesim::detail
