#pragma once
/// Collision detection between the tool's sphere tree and every object's sphere tree (DESIGN.md §4
/// step 1). Object trees are in world coordinates; the tool tree is in the tool frame and is placed
/// by a pose. The query prunes with inner spheres (dual traversal) and never allocates: the contact
/// set has a fixed capacity chosen when it is created.

#include <array>
#include <cstdint>
#include <limits>
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

 private:
  std::vector<Contact> items_;  // reserved once; never grows
  std::size_t size_ = 0;
  bool overflow_ = false;
};

/// The tool placed in the world for one query: world-space copies of its nodes, plus a per-leaf
/// margin (mm) by which each tool leaf is inflated (the largest distance it can move this sub-step).
class PlacedTool {
 public:
  explicit PlacedTool(const SphereTree& tool);
  /// Transforms every tool node by `pose`; `margin` inflates every leaf (and its ancestors).
  void place(const Pose& pose, double margin);
  /// As above with a per-leaf margin table (size = tool leaf count; an empty table keeps the margins
  /// of the previous call). Negative or non-finite margins count as zero.
  void place(const Pose& pose, std::span<const double> leaf_margin);
  [[nodiscard]] const SphereTree& tree() const { return *tool_; }
  [[nodiscard]] const Pose& pose() const { return pose_; }
  [[nodiscard]] std::span<const Vec3> centers() const { return centers_; }             ///< world, per node
  [[nodiscard]] std::span<const double> radii() const { return radii_; }               ///< per node, inflated
  [[nodiscard]] std::span<const double> leaf_margins() const { return leaf_margin_; }  ///< mm, per leaf

  /// Scratch of collide(): pairs reported per tool leaf for the object being traversed.
  struct LeafHits {
    uint32_t stamp = 0;
    uint32_t count = 0;
  };
  [[nodiscard]] std::span<LeafHits> leaf_hits() const { return leaf_hits_; }
  /// A fresh stamp for one object's traversal (the table is cleared when the stamps wrap).
  uint32_t next_hit_stamp() const;

 private:
  const SphereTree* tool_;
  Pose pose_;
  std::vector<Vec3> centers_;
  std::vector<double> radii_;        // inflated radii used for pruning and the pair test
  std::vector<double> leaf_margin_;  // per leaf
  mutable std::vector<LeafHits> leaf_hits_;  // collide()'s per-leaf counters (scratch, not state)
  mutable uint32_t hit_stamp_ = 0;
};

/// Pairs per (tool leaf, object) the haptic step asks collide() for: a large handle sphere pressed
/// into soft tissue overlaps hundreds of its leaves, which would crowd out every other contact from
/// a bounded pair list (the step keeps at most three rows per leaf and object).
inline constexpr uint32_t kStepPairsPerToolLeaf = 64;

/// Which objects take part in a query (bit i = object i); at most 64 objects.
using ObjectMask = uint64_t;
inline constexpr ObjectMask kAllObjects = ~ObjectMask{0};

/// Appends every (tool leaf, object leaf) pair whose gap is below the tool leaf's margin.
/// `gap` is computed with the true (uninflated) radii. Leaves flagged kLeafInterior of
/// `surface_only` objects are skipped; each tool leaf reports at most `max_per_leaf` pairs per object
/// (the first found, depth first; not necessarily the nearest).
void collide(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
             ContactSet& out, uint32_t max_per_leaf = std::numeric_limits<uint32_t>::max());

/// Sphere-against-sphere geometry of a pair, computed on demand (collide() reports ids and gaps only).
struct ContactGeometry {
  Vec3 normal;  ///< unit, from the object sphere's centre toward the tool sphere's centre
  Vec3 point;   ///< mm, world, on the object sphere's surface along `normal`
  Vec3 lever;   ///< mm, world, tool sphere centre minus tool-frame origin
};
/// The geometry of `contact` with the tool where it is placed; when the two centres coincide the
/// normal is the tool's +z axis (backing the tool out along its axis).
ContactGeometry contact_geometry(const PlacedTool& tool, std::span<const CollisionObject> objects,
                                 const Contact& contact);

/// Smallest gap between any tool leaf and any leaf of the masked objects, with the pair that gives it
/// (no allocation). Returns +infinity when nothing is within `search_mm`.
struct ClosestPair {
  double gap = 0.0;  ///< mm
  uint16_t tool_leaf = 0;
  uint16_t object = 0;
  uint32_t object_node = 0;
};
ClosestPair closest(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                    double search_mm);

}  // namespace cariesim
