#pragma once
// The haptic step as a sequence of stages (DESIGN.md §4; docs/step.md draws it).
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
//   collision   (pairs.cpp)        tool tree vs object trees within each leaf's reach -> PairSet: the
//                                  sphere pairs with their geometry at g0, measured once
//   regions     (regions.cpp)      pairs grouped per object and nearby tool point, deepest first ->
//                                  RegionSet: the unit of compliance and friction
//   anchors     (friction.cpp)     each sticking anchor meets its region of this solve and is laid into
//                                  its tangent plane (the only place an anchor moves before a solve)
//   rows        one builder per row kind, each owning its warm-start key space -> RowSet:
//                 contact_rows.cpp  non-penetration rows (eq. 1's constraint; compliant rows regularised)
//                 friction.cpp      two tangent equality rows per sticking anchor (§3.2, Figs. 10-11)
//                 tunnel.cpp        the virtual tunnel's rows (Fig. 5, eqs. 6-9)
//   solve       (solve.cpp)        the QP -> Solution: displacement, multipliers, per-region normal
//                                  force, and every QP status that is not Optimal as a StepFlag
//   slip        (friction.cpp)     once per sub-step, after the final solve: the Coulomb cone decides
//                                  which anchors stick, slip (moved onto the dynamic cone) or release
//                                  -> SlipPlan, applied between two solves; then the rows are solved again
//   re-check    (pairs.cpp)        collision at the solution: a rigid overlap adds its pair (measured at
//                                  g0 like every other) and the sub-step is solved again; what remains
//                                  is backtracked (substep.cpp)
// One cycle (step.cpp): check the input; the state machine (paper Fig. 4) runs the sliding state
// (sub-steps of bounded motion until the hand is reached, DESIGN.md §4 step 3; new anchors; what the
// tip touches) or the penetration state (tunnel.cpp: eqs. 3-5 and 8-9 move the tunnel's bottom, one
// sub-step with the tunnel's rows and the additional contacts of Fig. 7); then the output stage
// (output.cpp) fills the StepOutput, the only place that writes it, with the one force clamp.
//
// Data that lives longer than a stage: StateImpl (state_impl.hpp) holds the history (graphic pose,
// interaction state, tunnel, anchors, tip contact) and every stage's output, reserved once.

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/solver/qp.hpp"

namespace cariesim {

struct StateImpl;

namespace detail {

inline constexpr int kMaxAnchors = 8;            ///< simultaneously sticking contact regions
inline constexpr int kMaxRegions = 32;           ///< contact regions per solve
inline constexpr int kMaxPairs = 512;            ///< sphere pairs kept for the rows of one sub-step
/// Work units (WorkBudget) of one solve: regions, anchors, rows and the QP (about 3.3 us against 12 ns
/// a node pair, fitted on step_bench's trajectories).
inline constexpr int64_t kSolveWork = 280;
inline constexpr double kTipRegion = 0.3;        ///< mm: tool leaves this close to the tip count as "the tip"
inline constexpr double kRegionRadius = 1.0;     ///< mm: tool leaves this close share a contact region
inline constexpr int kMaxRowsPerGroup = 3;       ///< rows per rigid (tool leaf, object) or compliant region
inline constexpr double kRigidNormalCos = 0.97;  ///< rigid rows closer in direction are redundant
inline constexpr double kCompliantNormalCos = 0.9;  ///< compliant rows closer would add stiffness
/// mm: a compliant direction up to this much deeper than the shallowest pushes with the tissue's
/// stiffness; deeper, its stiffness fades linearly, to none at twice this (compliant_depth_fade).
inline constexpr double kCompliantDepthSlack = 0.05;
/// The share (0-1] of the tissue's stiffness a compliant direction `depth` (mm) deep pushes with when
/// the region's shallowest is `shallowest` (mm); 0 when it makes no row.
double compliant_depth_fade(double depth, double shallowest);
inline constexpr int kMaxCarried = 16;  ///< pairs carried from one solve to the next (CarriedPairs)

/// 6-D difference (translation mm, rotation vector rad) that moves `from` onto `to`.
Vec6 config_difference(const Pose& to, const Pose& from);
/// `g` moved by a 6-D displacement (rotation about the tool-frame origin, world axes).
Pose apply_displacement(const Pose& g, const Vec6& d);

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

// Stage 1, collision (pairs.cpp): DESIGN.md §4 step 1.

/// A sphere pair, by ids.
struct PairRef {
  uint32_t object_node = 0;
  uint16_t tool_leaf = 0;
  uint16_t object = 0;
  bool forced = false;  ///< found overlapping at a solution by the re-check: always gets its own row
  bool carried = false;  ///< bore load at the last solve (CarriedPairs): its row is kept
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
  /// Measured against a tangent on an internal boundary: a healthy leaf's patch on a lesion's wall.
  bool internal = false;
};

/// The collision stage's output: the pairs the rows of one sub-step are made of, each with its
/// geometry at the rows' configuration `at` (measured once, by measure_pair).
struct PairSet {
  std::array<PairRef, kMaxPairs> refs{};
  std::array<PairGeometry, kMaxPairs> geometry{};  ///< at `at`
  Pose at;                ///< the configuration the geometry is measured at (the sub-step's start g0)
  int count = 0;          ///< pairs in use
  bool overflow = false;  ///< more pairs qualified than the contact capacity or kMaxPairs hold
};

/// Scratch of the collision stage, reserved once.
struct CollisionScratch {
  explicit CollisionScratch(const Model& model);
  PlacedTool placed;
  ContactSet contacts;
  ReachMargins margins;             ///< this sub-step's tool leaf margins (set_leaf_margins)
  std::vector<uint32_t> order;      ///< contact capacity
  std::vector<uint16_t> rank;       ///< contact capacity
  /// Where each (tool leaf, object) group ends in `order` (tool leaves x objects + 1; collect_pairs'
  /// counting sort), and the objects it was sized for.
  std::vector<uint32_t> group_end;
  std::size_t group_objects = 0;
  /// Objects whose every pair within the leaf margins of the last collect_pairs is in `contacts`
  /// (none truncated): the re-check and the backtrack of that sub-step read their pairs from there
  /// instead of traversing the trees again. Cleared when `contacts` is reused for another query.
  ObjectMask complete = 0;
  ContactSet capped_overlaps{kMaxPairs};  ///< the re-check's overlaps of capped (tool leaf, object)s
  WorkBudget budget;                      ///< this step's (StepSettings::work_budget), reset by step()
  /// Work units up to which a further sub-step may start: StepSettings::work_budget times the cycle's
  /// share of kWorkBudgetCycle (at most all of it); set by step().
  int64_t substep_budget = 0;
};

/// Every tool leaf's margin (mm): the largest distance it can move under a displacement bounded by
/// `trans` (mm) and `rot` (rad), plus the model's contact margin.
void set_leaf_margins(const Model& m, double trans, double rot, CollisionScratch& c);
/// The geometry of pair `p` at configuration g. Rigid leaves, and leaves without tangent patches, are
/// measured sphere against sphere; a compliant leaf against the tangent patch facing the tool while
/// the tool lies over it (a caries leaf's wall patches excepted).
PairGeometry measure_pair(const Model& m, const ModelConstants& k, const Pose& g, const PairRef& p);
/// Collects the pairs within the leaf margins at g0 and measures them there (replaces `out`). When
/// more qualify than fit, each (tool leaf, object) keeps its nearest, the same number for all.
/// Returns false on overflow.
bool collect_pairs(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g0,
                   ObjectMask mask, PairSet& out);
/// collect_pairs' order when more pairs qualify than kMaxPairs: the first `found` contacts of
/// c.contacts by (tool leaf, object, gap) into `order`, by counting on (tool leaf, object) and
/// inserting each of those groups (at most a quota of pairs) by gap. With distinct gaps in every group
/// that is the one order any sort gives; returns false (order unspecified) when a group holds two
/// equal or unordered (NaN) gaps, which std::sort orders its own way, so that the caller sorts with it.
/// Issue #11: std::sort of those 513-1 024 pairs was a seventh of the 4 kHz steps of servo-touch-46
/// whose working end is pressed into lesion #1's caries (30 tool leaves, 16 pairs each).
bool group_pairs(CollisionScratch& c, std::size_t found, std::span<uint32_t> order);

/// What the re-check at a solution found.
struct Recheck {
  double worst = 0.0;  ///< mm, smallest gap to the rigid objects in the mask (0 when nothing is near)
  int added = 0;       ///< pairs added to the PairSet or given a row (marked forced)
};
/// Re-check at the solution g1: when the tool overlaps a rigid object in `mask` by more than the
/// tolerance, every such pair not yet in `pairs` joins it (forced, measured at pairs.at).
/// g1 must lie within the sub-step's bounds of pairs.at (every tool leaf moved by less than its
/// margin less the contact margin): a pair that can then overlap was within its margin at pairs.at,
/// so for objects whose pair list is complete (CollisionScratch::complete) the list is searched
/// instead of the trees. Rigid objects are met only at their surface (collide() skips their interior
/// fillers, CollisionObject::surface_only), so the two agree.
Recheck recheck_rigid(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g1,
                      ObjectMask mask, PairSet& pairs);
/// True when a pair of the last collection in `c.contacts` (any leaf pair, from any configuration) lies
/// within `reach_mm` of each other with the tool at g: then the tool is not in free space, and no
/// tree needs searching to say so.
bool listed_within(const Model& m, const ModelConstants& k, const CollisionScratch& c, const Pose& g,
                   double reach_mm);
/// Smallest gap (mm) between the tool at g and the rigid objects in `mask`; 0 when nothing overlaps.
/// As recheck_rigid: g within the sub-step's bounds; complete pair lists are searched instead of trees.
double rigid_clearance(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g,
                       ObjectMask mask);

// Stage 2, regions (regions.cpp).

/// The contacts of one object near one point of the tool: the unit of compliance (one row per
/// direction on compliant tissue, so stiffness does not depend on how many spheres overlap) and of
/// friction (one stick constraint per region).
struct Region {
  Vec3 tool_point_local = Vec3::Zero();  ///< mm, tool frame: centre of the deepest tool leaf
  Vec3 normal = Vec3::UnitZ();           ///< unit, world, of the deepest pair
  double gap = 0.0;                      ///< mm, of the deepest pair
  uint16_t object = 0;
  uint16_t material = 0;
  uint16_t tool_leaf = 0;
  int16_t pair = -1;  ///< the deepest pair, which founded the region
  bool compliant = false;
  bool tip = false;  ///< one of its tool leaves lies within the tip region
  /// mm, sideways distance of the founding tool leaf from the patch of the part the region is
  /// attributed to (`object`, `material`); +infinity when measured sphere against sphere.
  double lateral = std::numeric_limits<double>::infinity();
};

/// The regions stage's output.
struct RegionSet {
  std::array<Region, kMaxRegions> regions{};
  int count = 0;
  std::array<int16_t, kMaxPairs> order{};        ///< the pairs, deepest first
  /// Scratch of the sort: each pair's gap (mm) beside its index, so that the sort reads no geometry.
  struct GapKey {
    double gap;
    int16_t pair;
  };
  std::array<GapKey, kMaxPairs> keys{};
  std::array<GapKey, kMaxPairs> bucketed{};           ///< scratch of the sort: the keys sorted by buckets
  std::array<uint16_t, kMaxPairs + 1> bucket_end{};  ///< scratch of the sort: where each bucket ends
  std::array<int16_t, kMaxPairs> pair_region{};  ///< region of each pair, -1 for none (a wall, or full)
  int pairs = 0;  ///< pairs the set was built from (forced pairs added later belong to no region yet)
};

/// Sorts the pairs by gap and groups them into regions: same object, tool points within
/// kRegionRadius of the deepest pair's, which founds the region.
void build_regions(const Model& m, const ModelConstants& k, const PairSet& pairs, RegionSet& out);

// Stage 3, rows: one builder per row kind.

/// What a QP row stands for.
enum class RowKind : uint8_t { Contact, Friction, TunnelLateral, TunnelRotation, TunnelBottom, TunnelHold };

struct RowMeta {
  RowKind kind = RowKind::Contact;
  int16_t region = -1;  ///< contact region of a Contact or Friction row
  int16_t anchor = -1;  ///< anchor slot of a Friction row
  int16_t pair = -1;    ///< pair index of a Contact row
};

/// The rows stage's output: the QP problem and what each row stands for.
struct RowSet {
  QpProblem problem;
  std::array<RowMeta, kQpMaxRows> meta{};
  int contacts = 0;   ///< contact rows
  bool full = false;  ///< a row did not fit (kFlagQpRowsFull)
  /// The two tangent rows of each anchor, -1 when it has none in this problem.
  std::array<std::array<int8_t, 2>, kMaxAnchors> anchor_rows{};

  /// Empties the set for a problem with weight G and target x_target.
  void clear(const Mat6& G, const Vec6& x_target);
  /// Appends a row; false (and `full` set) when the problem has no room.
  bool add(const QpRow& row, const RowMeta& row_meta);
};

// Warm-start keys (QpRow::key). A row keeps its key from one solve to the next, so the QP can start
// from the rows that were active last time. Each row builder owns one key space, told apart by the
// top 16 bits:
//   contact rows   the object index (< 64) | tool leaf (bits 32-47) | object node (bits 0-31)
//   tunnel rows    kTunnelKeys | TunnelRow
//   friction rows  kFrictionKeys | 2 anchor + tangent
inline constexpr uint64_t kTunnelKeys = uint64_t{0x7A00} << 48;
inline constexpr uint64_t kFrictionKeys = uint64_t{0xF1C0} << 48;
static_assert((kTunnelKeys >> 48) >= 64 && (kFrictionKeys >> 48) >= 64,
              "key spaces overlap the contact rows'");

/// Key of a contact row (contact_rows.cpp).
inline constexpr uint64_t contact_key(const PairRef& p) {
  return (uint64_t{p.object} << 48) | (uint64_t{p.tool_leaf} << 32) | p.object_node;
}
/// Key of tangent row `tangent` (0, 1) of anchor slot `anchor` (friction.cpp).
inline constexpr uint64_t friction_key(int anchor, int tangent) {
  return kFrictionKeys | static_cast<uint64_t>(2 * anchor + tangent);
}
/// The tunnel's rows (tunnel.cpp), which are also their keys' low bits.
enum class TunnelRow : uint64_t {
  Lateral0 = 0x00,
  Lateral1 = 0x01,
  Rotation0 = 0x10,
  Rotation1 = 0x11,
  Rotation2 = 0x12,
  Bottom = 0x20,
  Hold = 0x21,
};
/// Key of a tunnel row.
inline constexpr uint64_t tunnel_key(TunnelRow row) { return kTunnelKeys | static_cast<uint64_t>(row); }

/// Scratch of the contact row builder: the pairs already given rows (a rigid (tool leaf, object)) or
/// elected (a compliant region), stamped per build so that nothing is cleared.
struct ContactRowScratch {
  explicit ContactRowScratch(const ModelConstants& k);
  struct PairGroup {
    uint64_t stamp = 0;  ///< equals `stamp` when the group belongs to the current build
    uint16_t object = 0;
    uint8_t count = 0;
    std::array<int16_t, kMaxRowsPerGroup> pairs{};  ///< pair indices
  };
  std::array<PairGroup, kMaxRegions> region_groups{};  ///< compliant regions: elected pairs
  std::vector<PairGroup> leaf_groups;  ///< two per tool leaf (a leaf may touch two rigid objects)
  uint64_t stamp = 0;
};

/// Contact rows (contact_rows.cpp): a few rows with distinct normals per rigid (tool leaf, object);
/// per compliant region one row per distinct surface direction, of compliance 1/stiffness.
/// `hold_only`: rigid rows never demand moving out of an existing overlap (inside the tunnel).
/// Returns the rows added.
int build_contact_rows(const Model& m, const Params& p, const PairSet& pairs, const RegionSet& regions,
                       bool hold_only, ContactRowScratch& scratch, RowSet& rows);

/// A sticking contact (paper §3.2, DESIGN.md §4 step 4): the tool point is held at `anchor` in the
/// tangent plane while the tangential load stays inside the static cone.
struct FrictionAnchor {
  Vec3 point_local = Vec3::Zero();  ///< mm, tool frame
  Vec3 anchor = Vec3::Zero();       ///< mm, world
  uint16_t object = 0;
  int16_t region = -1;  ///< its region in the current solve (set by attach_anchors)
  bool active = false;
};
using Anchors = std::array<FrictionAnchor, kMaxAnchors>;

/// Anchors stage (friction.cpp), before the rows of each solve: every active anchor finds its region
/// (released when the tool left it) and is laid into that region's tangent plane at g0.
void attach_anchors(const RegionSet& regions, const Pose& g0, Anchors& anchors);
/// Friction rows (friction.cpp): two tangent equality rows per attached anchor,
/// t_j·(dp + dθ × a) = t_j·(anchor - x).
void build_friction_rows(const Anchors& anchors, const RegionSet& regions, const Pose& g0, RowSet& rows);

/// The virtual tunnel of the penetration state (paper §3.3.1, Fig. 5).
struct Tunnel {
  Vec3 entry = Vec3::Zero();       ///< mm, world, tip centre when insertion began
  Vec3 n = Vec3::UnitZ();          ///< insertion direction, frozen at entry (unit)
  Quat q_lock = Quat::Identity();  ///< tool orientation held by the tunnel
  double depth = 0.0;              ///< mm, tip-centre travel along n since entry
  double max_depth = 0.0;          ///< mm, travel at which the tip reaches the lesion's bottom
  double depth0 = 0.0;             ///< mm, how deep the tip's apex was below the surface at entry
  int16_t lesion = -1;
  int16_t object = -1;  ///< the lesion's caries tree, left out of collision while inside
  uint16_t material = 0;
};

/// The tunnel's limits for one cycle: the tip's travel along n stays in [lower, upper] (mm).
struct TunnelLimits {
  const Tunnel* tunnel = nullptr;
  double lower = 0.0;  ///< mm, shallowest travel allowed (the tissue's hold, eq. 9)
  double upper = 0.0;  ///< mm, deepest travel allowed (the bottom sphere, moved by eq. 5)
};
/// Tunnel rows (tunnel.cpp): two lateral equalities (the four side spheres), three rotation
/// equalities (eq. 7's lock), the bottom sphere and the tissue's hold.
void build_tunnel_rows(const TunnelLimits& limits, const Pose& g0, RowSet& rows);

// Stage 4, solve (solve.cpp).

/// The solve stage's output.
struct Solution {
  Vec6 d = Vec6::Zero();  ///< mm, rad: displacement from the rows' configuration (zero when infeasible)
  QpResult qp;            ///< multipliers per row (N; zero when infeasible) and the QP's status
  /// kFlagInfeasible (Infeasible, BadInput or a non-finite answer), kFlagQpActiveSetFull,
  /// kFlagQpIterationLimit.
  uint32_t flags = 0;
  std::array<double, kMaxRegions> region_force{};  ///< N, sum of each region's contact multipliers
};

/// The StepFlag bits a QP status raises (none for Optimal).
uint32_t flags_of(QpStatus status);
/// Solves the rows; maps the status to flags; sums each region's normal force.
void solve_rows(const RowSet& rows, const RegionSet& regions, QpSolver& solver, Solution& out);

/// Hysteresis of the contact rows (issue #11): the pairs whose contact rows bore load at the last
/// solve.
/// - Compliant: without it a tool pressed into a soft fissure chattered at half the servo rate: the
///   rows at one pose (two walls) put the solution where the election left one wall out, and the
///   rows there put it back. A carried compliant pair keeps its row while it overlaps, unless its
///   region has a row of a similar direction or the depth rule drops it (build_contact_rows pass 3).
/// - Rigid, of a (tool leaf, object) whose quota was full in the collection: which of that leaf's
///   pairs were listed is the traversal's choice, and the dedupe of pass 1 may give the row of the
///   pair that held the tool to a deeper one of a similar direction. The solution then slid into the
///   held pair by up to the rigid tolerance and a second sub-step pushed it back out (oral sliding:
///   4 % of the steps undid their first sub-step's 0.01 mm). A carried rigid pair gets its row.
struct CarriedPairs {
  std::array<PairRef, kMaxCarried> refs{};
  int count = 0;
};
/// Remembers the pairs of the contact rows with a positive multiplier that are compliant, or rigid of
/// a (tool leaf, object) in `capped` (at most kMaxCarried; none inside a tunnel, whose rows hold the
/// tool).
void remember_loaded_pairs(const PairSet& pairs, const RegionSet& regions, const RowSet& rows,
                           const Solution& solution, bool in_tunnel,
                           std::span<const ContactSet::Capped> capped, CarriedPairs& out);
/// Marks the carried pairs of the objects in `mask` in `pairs` (`carried`), adding those not listed
/// (measured at pairs.at) while there is room; the contact rows then keep their directions.
void mark_carried_pairs(const Model& m, const ModelConstants& k, const CarriedPairs& carried, ObjectMask mask,
                        PairSet& pairs);

// Stage 5, slip (friction.cpp): between the final solve of a sub-step and its re-solve.

/// What the friction cone decided for each anchor after a solve.
struct SlipPlan {
  enum class Action : uint8_t { Keep, Release, Slip };
  std::array<Action, kMaxAnchors> action{};
  std::array<Vec3, kMaxAnchors> anchor{};  ///< mm, world: where a slipping anchor moves
  int changed = 0;                         ///< anchors released or moved (the rows must be solved again)
  int slipped = 0;                         ///< anchors moved (saw-tooth events)
};
/// The Coulomb cone after a solve at g0 (paper §3.2, Figs. 10-11): an anchor whose tangential load
/// left the static cone slips, its anchor moved so that the load falls onto the dynamic cone; an
/// anchor without normal load releases; the others stick. `G` is the coupling of the solve.
void decide_slips(const Params& p, const Anchors& anchors, const RegionSet& regions, const RowSet& rows,
                  const Solution& solution, const Pose& g0, const Mat6& G, SlipPlan& plan);
/// Moves and releases the anchors as planned.
void apply_slips(const SlipPlan& plan, Anchors& anchors);
/// Anchors for frictional regions under load that have none, at their tool point at g.
void create_anchors(const Params& p, const RegionSet& regions, const Solution& solution, const Pose& g,
                    Anchors& anchors);
/// Drops every anchor.
void release_anchors(Anchors& anchors);

// The sub-step (substep.cpp) and the cycle (step.cpp, tunnel.cpp, output.cpp).

/// What the stages of one cycle report, turned into the StepOutput by the output stage.
struct StepTrace {
  uint32_t flags = 0;  ///< StepFlag bits
  int contacts = 0;    ///< contact rows in the final solve
  int substeps = 0;    ///< sub-steps taken
  int slips = 0;       ///< anchors that slipped
  int64_t work = 0;    ///< node pairs the collision queries visited
};

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
};
/// A sub-step's first solve's motion before it was shortened onto the bounds.
struct SubstepMotion {
  double trans = 0.0;  ///< mm
  double rot = 0.0;    ///< rad
};
/// Solves one sub-step from g0 (paper eq. 1 linearised: DESIGN.md §4 steps 1-4): the graphic tool is
/// pulled toward the full target but moves at most by the bounds (the solution is shortened onto
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

/// The sliding state for one cycle (paper §3.2): bounded sub-steps toward the haptic tool, friction on
/// caries, then new anchors and what the tip touches.
void sliding_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, StepTrace& trace);
/// What the tool touches at g after the sub-steps: whether anything (sliding rather than free), and
/// the caries the tip sank into and how deep (the penetration criteria of the next cycle).
bool sense_tip(const Model& m, const Params& p, StateImpl& s, const Pose& g);

/// Sliding -> penetration (paper §3.1 criteria, eqs. 3-4): the tip touched caries in the last cycle and
/// the insertion force along the tip axis exceeds F_p*. Opens the tunnel and returns true.
bool try_enter_penetration(const Model& m, const Params& p, StateImpl& s, const Pose& haptic);
/// The tunnel's limits for this cycle: depth growth (eq. 5), holding and extraction (eqs. 8-9); may
/// switch between inserting and extracting.
TunnelLimits tunnel_limits(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt);
/// One cycle inside the lesion: the tunnel rows with the additional contacts in one sub-step (Fig. 7);
/// at full extraction the state returns to sliding.
void penetration_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt,
                      StepTrace& trace);
/// The five tunnel spheres for display (Fig. 5).
void tunnel_spheres(const Model& m, const StateImpl& s, TunnelSpheres& out);

/// The output stage (output.cpp), the only writer of a StepOutput: force and torque from the
/// graphic/haptic difference (eqs. 2, 6, 7) clamped to Params::limits, the state, the contact
/// summaries and the trace; step_us from `start` to now.
StepOutput make_output(const Model& m, const Params& p, const StateImpl& s, const Pose& haptic,
                       const StepTrace& trace, std::chrono::steady_clock::time_point start);
/// The output of a step refused because the state or params were made for another model.
StepOutput refused_output();

}  // namespace detail
}  // namespace cariesim
