#pragma once
/// The haptic step: `step(model, params, state, input) -> output` (docs/design.md §4; its stages are
/// described in src/render/stages.hpp and docs/step.md). A pure function of its inputs, so runs are
/// deterministic and replayable. It allocates nothing, takes no lock and does no
/// I/O. Bad input (non-finite pose, a jump of centimetres, a wedged tool, contact overflow) yields a
/// finite, bounded output with flags set, never a crash, NaN, or a tool inside rigid tissue.

#include <array>
#include <cstdint>
#include <memory>

#include "cariesim/render/interaction.hpp"
#include "cariesim/render/model.hpp"

namespace cariesim {

/// N, the axial force (|F_p| of eqs. 3-4) the decayed tissue resists the tip's advance with at apex
/// depth `apex_depth` (mm): k_c(depth)·crush_length, our reading of eq. 5 (docs/penetration.md).
double insertion_resistance(const Material& caries, double apex_depth);

/// One contact as reported to the viewer / logs (the strongest few).
struct ContactReport {
  Vec3 point;    ///< mm, world
  Vec3 normal;   ///< unit, world (out of the object)
  double force;  ///< N, normal force magnitude
  uint16_t object;
  uint16_t tool_leaf;
};
inline constexpr int kMaxReportedContacts = 16;

/// The virtual tunnel's five spheres (paper Fig. 5): [0] on the axis below the tip, [1..4] around
/// the head. Valid while penetrating.
struct TunnelSpheres {
  std::array<Vec3, 5> centers;    ///< mm, world
  std::array<double, 5> radii{};  ///< mm
  Vec3 entry = Vec3::Zero();      ///< mm, world: the tip's centre when the insertion began
  Vec3 axis = Vec3::UnitZ();      ///< insertion direction n, frozen at entry (unit)
  double max_depth = 0.0;         ///< mm, apex depth below the surface at the lesion's bottom
  bool active = false;
};

/// One reading for the step. The step's input guard (device/input_guard.hpp) judges it against
/// Model::settings.input; its verdict is StepOutput::input_faults.
struct HapticInput {
  Pose pose;          ///< the haptic tool (device) pose, tool frame in world
  double dt = 0.001;  ///< s, servo period
  bool valid = true;  ///< false: the device has no reading (none yet, or its source ended)
  double age = 0.0;   ///< s, how old the reading is (servo time minus its stamp)
};

struct StepOutput {
  Pose graphic;                ///< the constrained proxy
  Pose haptic;                 ///< the (sanitised) haptic pose used
  Vec3 force = Vec3::Zero();   ///< N, to render on the device, at the tool-frame origin
  Vec3 torque = Vec3::Zero();  ///< N·mm, to render on the device, about the tool-frame origin
  InteractionState state = InteractionState::Free;
  double depth = 0.0;  ///< mm, insertion depth along the tunnel axis
  int lesion = -1;     ///< lesion being probed (penetration) or touched by the tip
  int contacts = 0;    ///< constraint rows from sphere pairs in the final solve
  uint32_t flags = 0;  ///< StepFlag bits
  /// InputFault bits (device/input_guard.hpp): the input guard's verdict on this reading, which the
  /// force safety layer zeroes the wrench on (ForceSafety::filter)
  uint32_t input_faults = 0;
  double normal_force = 0.0;  ///< N, the force along the contacts' net normal (inserted: the axis) (Fig. 16)
  double soft_tissue_force = 0.0;  ///< N, largest normal force on gingiva/tongue (damage events)
  int tip_tissue = -1;             ///< Tissue of the tip's contact, -1 when the tip touches nothing
  double step_us = 0.0;            ///< µs, wall time of this step
  int substeps = 0;                ///< sub-steps taken (trust region, docs/design.md §4 step 3)
  int64_t work = 0;                ///< work units the step spent (StepSettings::work_budget)
  int slips = 0;                   ///< friction anchors that slipped this step (saw-tooth events)
  std::array<ContactReport, kMaxReportedContacts> contact_reports{};
  int contact_report_count = 0;
  TunnelSpheres tunnel;
};

struct StateImpl;  // history and stage data; see src/render/state_impl.hpp and the stages' headers

/// Everything the step carries from one cycle to the next, plus scratch reserved at creation.
class State {
 public:
  /// Creates a state for `model` with the graphic tool at `start` if it is collision-free, else at
  /// model.tool_home.
  State(const Model& model, const Pose& start);
  ~State();
  State(State&&) noexcept;
  State& operator=(State&&) noexcept;

  [[nodiscard]] const Pose& graphic() const;
  [[nodiscard]] InteractionState interaction() const;
  [[nodiscard]] double depth() const;
  /// True when this state was made for `model` (same object and tool-leaf counts).
  [[nodiscard]] bool built_for(const Model& model) const;
  /// A diagnostic (bench/step_bench's `pairs`): the sphere pairs the rows of the last sub-step were
  /// made of (collected within the leaf margins, at most 512, with those the re-check and the carried
  /// rows added). A step that ran no sub-step (the tool in free space) leaves the count of the last.
  [[nodiscard]] int collected_pairs() const;

 private:
  friend struct StateAccess;  // the render module's own door to impl_ (src/render/state_impl.hpp)
  std::unique_ptr<StateImpl> impl_;
};

/// Advances the state by one servo cycle with the running `params` (materials, gains, limits; made
/// from model.defaults, with the Model's material count).
StepOutput step(const Model& model, const Params& params, State& state, const HapticInput& input);
/// The same with the model's authored parameters (model.defaults).
StepOutput step(const Model& model, State& state, const HapticInput& input);

}  // namespace cariesim
