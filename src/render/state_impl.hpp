#pragma once
// Private state of the haptic step: what carries over between cycles (graphic pose, interaction
// state, virtual tunnel, friction anchors, last tip contact) and scratch memory reserved when the
// state is created, so that the step itself never allocates.

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/solver/qp.hpp"

namespace cariesim {

inline constexpr int kMaxAnchors = 8;    ///< simultaneously sticking contact regions
inline constexpr int kMaxRegions = 32;   ///< contact regions per solve
inline constexpr int kMaxPairs = 512;    ///< sphere pairs kept for the rows of one sub-step

/// A sphere pair, by ids, so its geometry can be recomputed at any tool configuration.
struct PairRef {
  uint32_t object_node = 0;
  uint16_t tool_leaf = 0;
  uint16_t object = 0;
  bool forced = false;  ///< found overlapping at a solution: always gets its own row
};

/// The geometry of a pair at one configuration.
struct PairGeometry {
  Vec3 normal;       ///< unit: object sphere centre -> tool sphere centre, or the leaf's surface normal
  Vec3 lever;        ///< mm, tool sphere centre - tool-frame origin (world)
  double gap = 0.0;  ///< mm, negative = overlap
  /// mm: for a compliant surface leaf measured against its tangent plane, how far the tool lies
  /// sideways from the leaf's tangent point; +infinity for a sphere-against-sphere measure.
  double lateral = std::numeric_limits<double>::infinity();
  bool wall = false;  ///< a caries leaf with only wall patches (its interface with healthy tissue)
};

/// What a QP row stands for.
enum class RowKind : uint8_t { Contact, Friction, TunnelLateral, TunnelRotation, TunnelBottom, TunnelHold };

struct RowMeta {
  RowKind kind = RowKind::Contact;
  int16_t region = -1;  ///< contact region of a Contact row
  int16_t anchor = -1;  ///< anchor slot of a Friction row
  int16_t pair = -1;    ///< pair index of a Contact row
};

/// The contacts of one object near one point of the tool: the unit of compliance (one row per
/// region on compliant tissue, so stiffness does not depend on how many spheres overlap) and of
/// friction (one stick constraint per region).
struct Region {
  Vec3 tool_point_local;   ///< mm, tool frame: centre of the deepest tool leaf
  Vec3 normal;             ///< unit, world, of the deepest pair
  double gap = 0.0;        ///< mm, of the deepest pair
  double normal_force = 0.0;  ///< N, sum of the region's contact multipliers
  uint16_t object = 0;
  uint16_t material = 0;
  uint16_t tool_leaf = 0;
  int16_t pair = -1;       ///< the deepest pair, which founded the region
  bool compliant = false;
  bool tip = false;        ///< the deepest tool leaf lies within the tip region
};

/// A sticking contact (paper §3.2, DESIGN.md §4 step 4): the tool point is held at `anchor` in the
/// tangent plane while the tangential load stays inside the static cone.
struct FrictionAnchor {
  Vec3 point_local = Vec3::Zero();  ///< mm, tool frame
  Vec3 anchor = Vec3::Zero();       ///< mm, world
  uint16_t object = 0;
  bool active = false;
  int8_t rows[2] = {-1, -1};        ///< its two tangent rows in the current problem
  Vec3 tangents[2];                 ///< their directions (world)
  int16_t region = -1;
};

/// The virtual tunnel of the penetration state (paper §3.3.1, Fig. 5).
struct Tunnel {
  Vec3 entry = Vec3::Zero();  ///< mm, world, tip centre when insertion began
  Vec3 n = Vec3::UnitZ();     ///< insertion direction, frozen at entry (unit)
  Quat q_lock = Quat::Identity();  ///< tool orientation held by the tunnel
  double depth = 0.0;         ///< mm, tip-centre travel along n since entry
  double max_depth = 0.0;     ///< mm, travel at which the tip reaches the lesion's bottom
  double depth0 = 0.0;        ///< mm, how deep the tip's apex was below the surface at entry
  int16_t lesion = -1;
  int16_t object = -1;        ///< the lesion's caries tree, left out of collision while inside
  uint16_t material = 0;
};

struct StateImpl {
  explicit StateImpl(const Model& model);

  // History.
  Pose graphic;
  Pose last_haptic;
  bool have_haptic = false;
  InteractionState interaction = InteractionState::Free;
  Tunnel tunnel;
  std::array<FrictionAnchor, kMaxAnchors> anchors{};
  int16_t tip_lesion = -1;   ///< lesion whose caries the tip touched in the last step
  uint16_t tip_material = 0;
  double tip_sink = 0.0;     ///< mm, how deep the tip was in that caries
  uint64_t steps = 0;
  double last_motion = 0.0;    ///< mm, tool-origin translation of the graphic tool in the last cycle
  double last_rotation = 0.0;  ///< rad, its rotation in the last cycle

  // Model-derived constants.
  std::size_t object_count = 0;
  std::size_t tool_leaves = 0;
  ObjectMask all_mask = 0;
  ObjectMask rigid_mask = 0;
  std::vector<Vec3> leaf_local;      ///< mm, tool leaf centres in the tool frame
  std::vector<double> leaf_radius;   ///< mm
  std::vector<double> leaf_reach;    ///< mm, |leaf centre| (lever length)
  double max_reach = 0.0;            ///< mm, largest leaf_reach

  // Scratch (reserved once).
  PlacedTool placed;
  ContactSet contacts;
  std::vector<double> leaf_margin;
  std::vector<uint32_t> contact_order;  ///< scratch of collect_pairs (contact capacity)
  std::vector<uint16_t> contact_rank;   ///< scratch of collect_pairs (contact capacity)
  std::array<PairRef, kMaxPairs> pairs{};
  std::array<PairGeometry, kMaxPairs> geometry{};
  std::array<int16_t, kMaxPairs> order{};
  std::array<int16_t, kMaxPairs> pair_region{};  ///< region of each pair, -1 when unused
  int pair_count = 0;
  std::array<Region, kMaxRegions> regions{};
  int region_count = 0;
  /// Rows already made for a group of pairs (a compliant region, or a rigid (tool leaf, object)).
  struct RowGroup {
    uint64_t stamp = 0;   ///< equals row_stamp when the group belongs to the current row build
    uint16_t object = 0;
    uint8_t count = 0;
    std::array<int16_t, 3> rows{};
  };
  std::array<RowGroup, kMaxRegions> region_rows{};
  std::vector<RowGroup> leaf_rows;  ///< two per tool leaf (a leaf may touch two rigid objects)
  uint64_t row_stamp = 0;
  QpProblem problem;
  QpResult result;
  QpSolver solver;
  std::array<RowMeta, kQpMaxRows> meta{};
};

}  // namespace cariesim
