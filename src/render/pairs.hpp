#pragma once
// Stage 1, collision (pairs.cpp; docs/design.md §4 step 1): the sphere pairs the rows of one sub-step
// are made of, each measured once at the rows' configuration; the re-check at a solution; and the
// step's pair quota, how many pairs per (tool leaf, object) it asks collide() for.

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

/// Pairs per (tool leaf, object) the step asks collide() for: a large handle sphere pressed into soft
/// tissue overlaps hundreds of its leaves, which would crowd out every other contact from a bounded
/// pair list (the step keeps at most three rows per leaf and object).
inline constexpr uint32_t kStepPairsPerToolLeaf = 16;
/// The same for tool leaves farther than kRegionRadius from the tip (the working end, shank and
/// handle): a shank resting on a tooth touches it with dozens of leaves, each overlapping dozens of
/// the tooth's small leaves, and their nearest few already give its rows (at most three per leaf and
/// object).
inline constexpr uint32_t kStepPairsPerFarToolLeaf = 16;

/// A sphere pair, by ids.
struct PairRef {
  uint32_t object_node = 0;
  uint16_t tool_leaf = 0;
  uint16_t object = 0;
  bool forced = false;   ///< found overlapping at a solution by the re-check: always gets its own row
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
  ReachMargins margins;         ///< this sub-step's tool leaf margins (set_leaf_margins)
  std::vector<uint32_t> order;  ///< contact capacity
  std::vector<uint16_t> rank;   ///< contact capacity
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
/// Force shading (Morgenbesser and Srinivasan 1996; docs/step.md, "Force shading"): the surface's
/// normal at pair i's contact point (the tool sphere's point toward the object sphere): the object's
/// mesh normals interpolated at the mesh point nearest it (Model::shading_surfaces), leaned toward the
/// pair's sphere normal where the two differ by more than 10 degrees and the sphere normal beyond 15;
/// the pair's own normal where the object has no mesh or none lies within 0.03 mm. Allocates nothing.
Vec3 shaded_normal(const Model& m, const PairSet& pairs, int i);
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
/// (Why not std::sort alone: docs/performance.md, ninth round.)
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

inline constexpr int kMaxCarried = 16;  ///< pairs carried from one solve to the next (CarriedPairs)

/// Hysteresis of the contact rows: the pairs whose contact rows bore load at the last solve
/// (remembered by the solve stage, remember_loaded_pairs; docs/step.md, "Row builders").
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
/// Marks the carried pairs of the objects in `mask` in `pairs` (`carried`), adding those not listed
/// (measured at pairs.at) while there is room; the contact rows then keep their directions.
void mark_carried_pairs(const Model& m, const ModelConstants& k, const CarriedPairs& carried, ObjectMask mask,
                        PairSet& pairs);

}  // namespace cariesim::detail
