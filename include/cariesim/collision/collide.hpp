#pragma once
/// Collision detection between the tool's sphere tree and every object's sphere tree (docs/design.md
/// §4 step 1). Object trees are in world coordinates; the tool tree is in the tool frame and is placed
/// by a pose (PlacedTool). The queries prune with inner spheres (dual traversal) and never allocate:
/// the contact set has a fixed capacity chosen when it is created. The code: tool placement
/// (src/collision/placement.cpp), the traversals that collect pairs (traversal.cpp: collide(),
/// sphere_collide()) and the nearest-pair queries (nearest.cpp: closest(), any_within(),
/// sphere_closest()).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// How an object responds to contact.
enum class ObjectKind : uint8_t { Rigid, Soft };

/// One collidable object: a sphere tree in world coordinates and what it is.
struct CollisionObject {
  std::string name;  ///< e.g. "tooth46/healthy", "tooth46/lesion1"
  SphereTree tree;   ///< world coordinates (mm)
  ObjectKind kind = ObjectKind::Rigid;
  int16_t lesion = -1;        ///< lesion index when this is a caries tree, else -1
  int16_t host = -1;          ///< for a caries tree: index of the healthy object of the same tooth
  int16_t scene_object = -1;  ///< index of the scene object this tree came from
  /// Every leaf is rigid tissue: a tool meets it only at its surface, so collide() skips its
  /// kLeafInterior fillers (hundreds of redundant pairs in dense trees; closest() still sees them).
  bool surface_only = false;
};

/// One sphere pair closer than the query margin, by ids and sphere-against-sphere gap. What a pair
/// means for a constraint (its normal, lever, or a depth measured against a surface patch) is the
/// caller's to compute, at the configuration it needs (the haptic step: render's measure_pair).
struct Contact {
  double gap = 0.0;          ///< mm, |c_t - c_o| - r_t - r_o (negative = overlap)
  uint32_t object_node = 0;  ///< node index in the object's tree
  uint16_t tool_leaf = 0;    ///< leaf index in the tool's tree (0 = the tip)
  uint16_t object = 0;       ///< index into the object list
  uint16_t material = 0;     ///< the object leaf's material
  uint16_t pad = 0;
};

/// A fixed-capacity set of contacts. When more pairs qualify than fit, the ones with the smallest
/// gaps are kept and `overflow` is set.
class ContactSet {
 public:
  explicit ContactSet(std::size_t capacity = 1024);
  void clear();
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t capacity() const { return items_.size(); }
  [[nodiscard]] bool overflow() const { return overflow_; }
  [[nodiscard]] const Contact& operator[](std::size_t i) const { return items_[i]; }
  [[nodiscard]] std::span<const Contact> view() const { return {items_.data(), size_}; }
  /// Adds a pair, or replaces the worst (largest gap) one when full and `c` is better.
  void push(const Contact& c);
  /// Flags the set as incomplete without adding a pair (a query had to drop work it could not hold).
  void mark_overflow() { overflow_ = true; }
  /// A (tool leaf, object) whose quota of pairs was full: more of its pairs may qualify than are listed.
  struct Capped {
    uint16_t tool_leaf = 0;
    uint16_t object = 0;
  };
  static constexpr std::size_t kMaxCapped = 64;
  /// Notes that (tool leaf, object) may have left qualifying pairs out (its quota was full); beyond
  /// kMaxCapped such notes the set counts as truncated everywhere.
  void note_capped(uint16_t tool_leaf, uint16_t object) {
    if (capped_count_ < capped_.size()) capped_[capped_count_] = {tool_leaf, object};
    ++capped_count_;
  }
  /// The (tool leaf, object) combinations noted by note_capped.
  [[nodiscard]] std::span<const Capped> capped() const {
    return {capped_.data(), std::min(capped_count_, capped_.size())};
  }
  /// True when pairs may be missing anywhere (an overflow, or too many capped combinations); when
  /// false, every pair within the query's margins is in the set except those of capped() combinations.
  [[nodiscard]] bool truncated() const { return overflow_ || capped_count_ > capped_.size(); }

 private:
  std::vector<Contact> items_;  // reserved once; never grows
  std::size_t size_ = 0;
  bool overflow_ = false;
  std::array<Capped, kMaxCapped> capped_{};
  std::size_t capped_count_ = 0;
};

/// Margins (mm) that grow with a tool leaf's reach, the distance (mm) of its centre from the tool
/// frame's origin: (base + per_reach * reach) + extra, evaluated in that order; a negative or
/// non-finite result counts as zero. A sub-step that may move the origin by `base` and turn the tool by
/// `per_reach` rad moves a leaf by at most base + per_reach * reach.
struct ReachMargins {
  double base = 0.0;       ///< mm
  double per_reach = 0.0;  ///< mm per mm of reach (rad); a negative one counts as zero
  double extra = 0.0;      ///< mm
  /// The margin (mm) of a leaf at `reach` mm.
  [[nodiscard]] double at(double reach) const {
    const double m = base + std::max(per_reach, 0.0) * reach + extra;
    return std::isfinite(m) ? std::max(m, 0.0) : 0.0;
  }
};

namespace collision_detail {
struct ToolPlacement;  // the collision module's own (src/collision/placement.hpp)
}  // namespace collision_detail

/// The tool placed in the world for one query: world-space copies of its nodes, plus a per-leaf
/// margin (mm) by which each tool leaf is inflated (the largest distance it can move this sub-step).
/// The nodes' world positions are made as the queries reach them: place() moves the root, and
/// collide(), closest() and any_within() move an inner node's children when they split it, so a
/// query near the tip moves a few dozen of the tree's nodes. The accessors of world positions
/// (centers(), capsule_a(), ...) move whatever is left first, so what they return is always the whole
/// tool at pose(). The queries write a placed tool (its world copies, their per-leaf counters), so
/// they take it by non-const reference: one thread uses it at a time.
class PlacedTool {
 public:
  /// Checks the tool tree (children after their parent, leaf indices within the leaf table, at most
  /// 65 535 leaves; throws Error naming the node otherwise) and fits its tables once.
  explicit PlacedTool(const SphereTree& tool);
  ~PlacedTool();
  PlacedTool(PlacedTool&&) noexcept;
  PlacedTool& operator=(PlacedTool&&) noexcept;

  /// Places the tool at `pose` (its nodes move as the queries reach them); `margin` inflates every
  /// leaf (and its ancestors).
  void place(const Pose& pose, double margin);
  /// As above with a per-leaf margin table (size = tool leaf count; an empty table keeps the margins
  /// of the previous call). Negative or non-finite margins count as zero.
  void place(const Pose& pose, std::span<const double> leaf_margin);
  /// As above with margins that grow with each leaf's reach. An inner node grows by the margin of the
  /// farthest-reaching leaf below it, which is the largest of theirs, so each node's radius is made
  /// when a query reaches it, like its centre.
  void place(const Pose& pose, const ReachMargins& margins);
  [[nodiscard]] const SphereTree& tree() const;
  [[nodiscard]] const Pose& pose() const;
  /// World centres, per node.
  [[nodiscard]] std::span<const Vec3> centers();
  /// Inflated radii (mm), per node.
  [[nodiscard]] std::span<const double> radii();
  /// Margins (mm), per leaf.
  [[nodiscard]] std::span<const double> leaf_margins();
  /// A second bound for inner nodes whose leaves lie along a line (the explorer's shank and hook): a
  /// capsule, the segment from `a` to `a + d` (world) grown by `capsule_radii()` (mm, inflated like
  /// the node's sphere), holding every leaf below. Nodes where it is not tighter than the sphere have
  /// `has_capsule()` 0. collide() prunes a pair that misses either bound. Per node.
  [[nodiscard]] std::span<const Vec3> capsule_a();
  [[nodiscard]] std::span<const Vec3> capsule_d();             ///< world, per node
  [[nodiscard]] std::span<const double> capsule_radii();       ///< mm, inflated, per node
  [[nodiscard]] std::span<const uint8_t> has_capsule() const;  ///< per node
  /// Per-leaf quotas of pairs per object for collide() (each capped by its `max_per_leaf`); an empty
  /// table (the default) leaves `max_per_leaf` alone. Size = tool leaf count.
  void set_leaf_quota(std::span<const uint32_t> quota);
  [[nodiscard]] std::span<const uint32_t> leaf_quota() const;

  /// The placement's tables and the queries' scratch, for the collision module's queries: an opaque
  /// type outside it.
  [[nodiscard]] collision_detail::ToolPlacement& placement() { return *placement_; }

 private:
  std::unique_ptr<collision_detail::ToolPlacement> placement_;
};

/// A bound on the work of a sequence of queries (the haptic step's, docs/design.md §4), in work units: one
/// per node pair a traversal visits, kContactWork per pair pushed to a contact set (the pair test, the
/// set's heap when full, and the listing, measuring and row building that follow in the step), and
/// what the caller charges for its own work (the step: kSolveWork per QP solve). A query that runs out
/// stops where it is and says so (collide(): the contact set overflows; closest():
/// ClosestPair::complete is false; sphere_closest(): -infinity).
struct WorkBudget {
  int64_t left = std::numeric_limits<int64_t>::max();  ///< work units
  int64_t used = 0;                                    ///< work units spent so far
  /// Takes one unit (a node pair); false (and spent from then on) when none is left.
  bool take() { return charge(1); }
  /// Takes n units; when fewer are left, takes what is left, is spent from then on and returns false.
  bool charge(int64_t n) {
    if (left < n) {
      used += std::max<int64_t>(left, 0);
      left = -1;
      return false;
    }
    left -= n;
    used += n;
    return true;
  }
  [[nodiscard]] bool spent() const { return left < 0; }
};
/// Work units of one pair pushed to a contact set (WorkBudget; calibrated on step_bench's trajectories
/// and the extreme scene of docs/step.md's "Work budget": about 130 ns against 12 ns a node pair).
inline constexpr int64_t kContactWork = 10;

/// Which objects take part in a query (bit i = object i); at most 64 objects.
using ObjectMask = uint64_t;
inline constexpr ObjectMask kAllObjects = ~ObjectMask{0};

/// Appends every (tool leaf, object leaf) pair whose gap is below the tool leaf's margin.
/// `gap` is computed with the true (uninflated) radii. Leaves flagged kLeafInterior of
/// `surface_only` objects are skipped; each tool leaf reports at most `max_per_leaf` pairs per object
/// (or its PlacedTool::leaf_quota when lower; the nearest first as far as the depth-first descent, which
/// visits siblings nearest first, finds them): once its quota is full the traversal
/// no longer descends below that leaf for that object, and the combination is noted in `out.capped()`.
/// With a `budget`, each node pair visited takes one unit; when it is spent the traversal stops and
/// the set is marked overflowing.
void collide(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask, ContactSet& out,
             uint32_t max_per_leaf = std::numeric_limits<uint32_t>::max(), WorkBudget* budget = nullptr);

/// Sphere-against-sphere geometry of a pair, computed on demand (collide() reports ids and gaps only).
struct ContactGeometry {
  Vec3 normal;  ///< unit, from the object sphere's centre toward the tool sphere's centre
  Vec3 point;   ///< mm, world, on the object sphere's surface along `normal`
  Vec3 lever;   ///< mm, world, tool sphere centre minus tool-frame origin
};
/// The geometry of `contact` with the tool where it is placed; when the two centres coincide the
/// normal is the tool's +z axis (backing the tool out along its axis).
ContactGeometry contact_geometry(PlacedTool& tool, std::span<const CollisionObject> objects,
                                 const Contact& contact);

/// Smallest gap between any tool leaf and any leaf of the masked objects, with the pair that gives it
/// (no allocation). Returns +infinity when nothing is within `search_mm`.
struct ClosestPair {
  double gap = 0.0;  ///< mm
  uint16_t tool_leaf = 0;
  uint16_t object = 0;
  uint32_t object_node = 0;
  bool complete = true;  ///< false when the work budget ran out: a smaller gap may exist
};
ClosestPair closest(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                    double search_mm, WorkBudget* budget = nullptr);

/// Whether any tool leaf lies within `search_mm` of a leaf of the masked objects: the first such pair
/// found (nearest-first, so usually near the closest, but not necessarily it), or gap +infinity when
/// there is none. Stops at that first pair: the cheap question "is anything near?" when the answer
/// is usually yes (a tool in contact). `complete` as for closest().
ClosestPair any_within(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                       double search_mm, WorkBudget* budget = nullptr);

/// Smallest gap (mm) between one sphere (world centre, radius in mm) and the leaves of `object`
/// (without the kLeafInterior fillers of a `surface_only` object, as collide()), when below
/// `search_mm`; +infinity otherwise; -infinity when the work budget ran out first. No allocation.
double sphere_closest(const Vec3& center, double radius, const CollisionObject& object, double search_mm,
                      WorkBudget* budget = nullptr);

/// Every leaf of `object` (without the kLeafInterior fillers of a `surface_only` object) whose gap to
/// one sphere (world centre, radius in mm) is below `margin_mm`, pushed to `out` as contacts of tool
/// leaf `tool_leaf` with object index `object_index`. No allocation. A spent budget stops it and marks
/// `out` overflowing.
void sphere_collide(const Vec3& center, double radius, uint16_t tool_leaf, uint16_t object_index,
                    const CollisionObject& object, double margin_mm, ContactSet& out,
                    WorkBudget* budget = nullptr);

}  // namespace cariesim
