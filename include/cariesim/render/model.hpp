#pragma once
/// The immutable Model of the haptic step (docs/design.md §4, docs/style.md "Model / State / step"): object
/// trees, lesions, the tool, numerical settings, capacities, and the authored Params (materials,
/// gains, device limits). Built once from a scene (scene/model_builder.hpp) and never changed after; what
/// may change while the loop runs is a Params block (render/params.hpp) the caller owns.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/device/input_guard.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/nearest.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/render/material.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// A lesion as the engine needs it: where its caries tree is, its host tooth, its parameters.
struct LesionModel {
  std::string name;             ///< e.g. "lesion1"
  int16_t object = -1;          ///< index of its caries tree in Model::objects
  int16_t host = -1;            ///< index of the healthy tree of the same tooth
  uint16_t material = 0;        ///< index of its (top-layer) material in Model::materials
  LesionShape shape;            ///< authored shape, world coordinates
  double authored_depth = 0.0;  ///< mm, depth below the surface at the shape's centre
  std::string severity;         ///< "mild", "severe" or "" (authoring label)
};

/// The haptic tool.
struct ToolModel {
  ExplorerParams params;
  SphereTree tree;           ///< tool frame; leaf 0 is the tip sphere
  TriangleMesh display;      ///< tool frame
  double tip_radius = 0.05;  ///< mm
};

/// s, the cycle StepSettings::work_budget is for.
inline constexpr double kWorkBudgetCycle = 0.001;

/// Numerical settings of the step.
struct StepSettings {
  double trust_step = 0.1;         ///< mm, largest tool-leaf motion per sub-step (trust region)
  double trust_rotation = 0.02;    ///< rad, largest rotation per sub-step
  int max_substeps = 6;            ///< per step; the graphic tool lags behind beyond that
  int max_rechecks = 3;            ///< collision re-checks at the solution per sub-step
  double rigid_tolerance = 0.005;  ///< mm, allowed overlap with rigid leaves at the end of a step
  /// How each reading is judged (device/input_guard.hpp): a jump of more than max_jump (mm) or
  /// max_jump_rotation (rad) in one step is flagged and limited; the servo loop's force safety and
  /// the UDP bridge use the same limits (stale_after).
  InputLimits input;
  double contact_margin = 0.02;  ///< mm, extra margin when collecting contacts
  /// Force shading (docs/step.md, "Force shading"): the rendered force is turned from the rigid
  /// rows' sphere normals to the surface's normals at their contact points (the meshes' normals
  /// interpolated, Model::shading_surfaces), so that a smooth tooth renders smooth; the rows, and with
  /// them where the tool goes, stay the sphere pairs'. False: the coupling force as it is.
  bool force_shading = true;
  double reference_dt = 0.001;   ///< s, eq. 5 is per 1 ms cycle; depth growth scales by dt/this
  /// mm/s, the fastest the tip gives way inside a lesion: a breakthrough (resistance below F_p*)
  /// plays over several cycles instead of one force step (docs/penetration.md)
  double max_give_speed = 40.0;
  /// Work units one step may spend (docs/step.md "Work budget"; WorkBudget: a node pair visited is
  /// one, a pair pushed to a contact set kContactWork, a QP solve kSolveWork): bounds the step's time
  /// whatever the trees, the tool or the materials (12-40 ns a unit on one core of the reference
  /// machine). A further sub-step starts only while what is left covers the costliest sub-step so
  /// far; a query cut short counts as an overlap (the tool holds where it was clear); kFlagWorkBudget
  /// is set either way. The budget is per kWorkBudgetCycle: at a faster rate a further sub-step
  /// starts only within the cycle's share of it (0.25 of it at 4 kHz), while the first sub-step
  /// keeps all of it, so the work per second of simulated time is the same at any rate.
  int64_t work_budget = 30000;
};

/// Capacities fixed at build time (scratch memory is reserved then).
struct Capacities {
  std::size_t contacts = 1024;  ///< raw sphere pairs per query
};

/// Cold, display-only data of one scene object.
struct DisplayPart {
  std::string name;
  TriangleMesh mesh;  ///< world coordinates
  Tissue tissue = Tissue::Generic;
  int16_t lesion = -1;  ///< the lesion a caries part shows, else -1
  int16_t object = -1;  ///< its collision object
  bool cut = false;     ///< one of the parts of an object that lesions cut
  /// World coordinates; on the first (healthy) part of an object that lesions cut, the object's uncut
  /// surface, drawn instead of its parts while the lesions are hidden so that no seam between the
  /// parts outlines a lesion; empty otherwise.
  TriangleMesh whole;
};

struct Model {
  std::vector<CollisionObject> objects;  ///< all collidable trees (healthy, caries, soft tissue)
  std::vector<LesionModel> lesions;
  ToolModel tool;
  /// Materials, gains and device limits as authored: the start of every running Params block. A
  /// material's rigidity (infinite stiffness) and the material count are the Model's.
  Params defaults;
  StepSettings settings;
  Capacities capacities;
  double servo_rate = 1000.0;  ///< Hz
  Pose tool_home;              ///< a collision-free tool pose used when the state is created
  std::string scene_name;
  uint64_t scene_hash = 0;
  std::vector<DisplayPart> display;  ///< cold data for the viewer and reports
  /// Force shading's surfaces (docs/step.md, "Force shading"), by object: its display mesh with its
  /// vertex normals for nearest-point queries; empty for a compliant object or one without a mesh.
  std::vector<MeshNearest> shading_surfaces;
};

/// Whether an object is rigid: it has leaves and every leaf's material in `materials` (indexed by
/// SphereNode::material) is rigid (Material::rigid; an index outside `materials` is not). The one rule
/// for the model builder's CollisionObject::surface_only, the step's overlap re-check and the
/// experiments' rigid penetration; an object's kind only says how it is drawn and whether lesions may
/// sit on it.
[[nodiscard]] bool rigid_object(const SphereTree& tree, const std::vector<Material>& materials);
/// The model's rigid objects (rigid_object against model.defaults.materials): bit i for object i.
[[nodiscard]] ObjectMask rigid_objects(const Model& model);

}  // namespace cariesim
