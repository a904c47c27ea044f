// The traversals that collect pairs: collide(), the dual descent of the placed tool's tree against
// every object's tree, with each tool leaf's quota of pairs per object; sphere_collide(), one sphere
// against one object's tree; and contact_geometry(), a collected pair's geometry on demand.
#include "collision/traversal.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "cariesim/collision/collide.hpp"
#include "collision/placement.hpp"

namespace cariesim {

using collision_detail::kPruneSlack;
using collision_detail::kStackSize;
using collision_detail::LeafHits;
using collision_detail::prefetch_children;
using collision_detail::ToolPlacement;

namespace {

// mm; below this centre distance the direction between two spheres is taken as undefined.
constexpr double kCoincident = 1e-12;

struct NodePair {
  uint32_t tool;
  uint32_t object;
};

// Everything the traversal of one object reads, as raw pointers (no bounds checks in the hot loop).
struct Query {
  ToolPlacement* placed;           // moves a tool node's children before they are read
  const SphereNode* tool_nodes;    // tool frame radii (true), leaf ids
  const Vec3* tool_centers;        // world
  const double* tool_radii;        // inflated
  const double* leaf_margin;       // per tool leaf
  const Vec3* cap_a;               // per tool node, world (PlacedTool::capsule_a)
  const Vec3* cap_d;               // per tool node, world
  const double* cap_inv_dd;        // per tool node, 1/mm²
  const double* cap_r;             // per tool node, inflated (mm)
  const uint8_t* has_cap;          // per tool node
  const SphereNode* object_nodes;  // world
  uint16_t object;
  uint32_t skip_flags;           // object leaves with any of these flags are not reported
  LeafHits* hits;                // per tool leaf: pairs reported for this object (stamped)
  LeafHits* caps;                // per tool node: leaves below it capped for this object (stamped)
  const uint32_t* parent;        // per tool node
  const uint32_t* leaves_below;  // per tool node
  uint32_t stamp;                // this object's traversal
  uint32_t max_per_leaf;         // pairs a tool leaf may report for this object
  const uint32_t* leaf_quota;    // per tool leaf, lower quotas (null: max_per_leaf for all)
  WorkBudget* budget;            // node pairs the traversal may visit, or null
};

// Pairs tool leaf `leaf` may report for the object being traversed.
inline uint32_t quota(const Query& q, uint32_t leaf) {
  return q.leaf_quota != nullptr ? std::min(q.max_per_leaf, q.leaf_quota[leaf]) : q.max_per_leaf;
}

// True when a tool leaf has reported its quota of pairs for the object being traversed.
inline bool quota_full(const Query& q, const SphereNode& tool_node) {
  const LeafHits& hits = q.hits[tool_node.leaf];
  return tool_node.is_leaf() && hits.stamp == q.stamp && hits.count >= quota(q, tool_node.leaf);
}

// True when every leaf below tool node t (t itself for a leaf) has left out a pair for the object
// being traversed (is capped): nothing more below t need be tested.
inline bool all_capped(const Query& q, uint32_t t) {
  const LeafHits& caps = q.caps[t];
  return caps.stamp == q.stamp && caps.count >= q.leaves_below[t];
}

// A pair of tool leaf node t whose quota is full is left out: the first time, note the combination
// (the count goes one past the quota to remember it) and count the leaf as capped in every ancestor.
inline void leave_out(const Query& q, uint32_t t, ContactSet& out) {
  const uint32_t leaf = q.tool_nodes[t].leaf;
  LeafHits& hits = q.hits[leaf];
  if (hits.count != quota(q, leaf)) return;
  ++hits.count;
  out.note_capped(static_cast<uint16_t>(leaf), q.object);
  for (uint32_t n = t;; n = q.parent[n]) {
    LeafHits& caps = q.caps[n];
    if (caps.stamp != q.stamp) caps = {q.stamp, 0};
    ++caps.count;
    if (n == q.parent[n]) break;
  }
}

// Squared distance (mm²) between the centres of a tool node and an object node.
inline double distance2(const Query& q, uint32_t t, uint32_t o) {
  return (q.tool_centers[t] - q.object_nodes[o].center.cast<double>()).squaredNorm();
}

// True when a tool node (inflated) and an object node whose centres lie sqrt(d2) apart overlap,
// within the pruning slack.
inline bool overlaps(const Query& q, uint32_t t, uint32_t o, double d2) {
  const double reach = q.tool_radii[t] + static_cast<double>(q.object_nodes[o].radius) + kPruneSlack;
  return d2 < reach * reach;
}
inline bool overlaps(const Query& q, uint32_t t, uint32_t o) { return overlaps(q, t, o, distance2(q, t, o)); }

// True unless tool node t has a capsule (an inner node whose leaves lie along a line) that misses
// object node o, within the pruning slack. Both bounds hold every leaf below t (inflated), so a pair
// that misses either has no leaf pair within the margins.
[[gnu::always_inline]] inline bool capsule_overlaps(const Query& q, uint32_t t, uint32_t o) {
  if (q.has_cap[t] == 0) return true;
  const SphereNode& on = q.object_nodes[o];
  const Vec3 w = on.center.cast<double>() - q.cap_a[t];
  const Vec3& d = q.cap_d[t];
  const double s = std::clamp(w.dot(d) * q.cap_inv_dd[t], 0.0, 1.0);
  const double reach = q.cap_r[t] + static_cast<double>(on.radius) + kPruneSlack;
  return (w - s * d).squaredNorm() < reach * reach;
}

// A node pair with its squared centre distance (mm²), for ordering siblings.
struct DistPair {
  double d2;
  uint32_t tool;
  uint32_t object;
};
// Children per inner node at most (build_hierarchy's largest branching).
constexpr int kMaxChildren = 8;

// Insertion sort of at most kMaxChildren pairs, farthest first.
inline void sort_far_first(DistPair* kids, int count) {
  for (int k = 1; k < count; ++k) {
    const DistPair moving = kids[k];
    int j = k;
    for (; j > 0 && kids[j - 1].d2 < moving.d2; --j) kids[j] = kids[j - 1];
    kids[j] = moving;
  }
}

// The exact leaf-pair test with the true radii; pushes a contact when the gap is below the tool
// leaf's margin.
inline void emit(const Query& q, uint32_t t, uint32_t o, ContactSet& out) {
  const SphereNode& tn = q.tool_nodes[t];
  const SphereNode& on = q.object_nodes[o];
  if (on.flags & q.skip_flags) return;
  if (all_capped(q, t)) return;
  const Vec3 d = q.tool_centers[t] - on.center.cast<double>();
  const double gap = d.norm() - static_cast<double>(tn.radius) - static_cast<double>(on.radius);
  if (!(gap < q.leaf_margin[tn.leaf])) return;
  LeafHits& hits = q.hits[tn.leaf];
  if (hits.stamp != q.stamp) hits = {q.stamp, 0};
  if (hits.count >= quota(q, tn.leaf)) {
    leave_out(q, t, out);
    return;
  }
  ++hits.count;
  if (q.budget != nullptr) q.budget->charge(kContactWork);  // a spent budget stops the next pop
  Contact c;
  c.gap = gap;
  c.object_node = o;
  c.tool_leaf = static_cast<uint16_t>(tn.leaf);
  c.object = q.object;
  c.material = on.material;
  out.push(c);
}

// Dual traversal of the placed tool against one object tree: pop a pair known to overlap, split the
// node with the larger sphere (a leaf is never split), keep the children that still overlap, and
// test leaf pairs exactly.
void traverse(const Query& q, ContactSet& out) {
  if (!overlaps(q, 0, 0) || !capsule_overlaps(q, 0, 0)) return;
  std::array<NodePair, kStackSize> stack;
  int top = 0;
  stack[top++] = {0, 0};
  while (top > 0) {
    const NodePair pair = stack[--top];
    if (q.budget != nullptr && !q.budget->take()) {
      out.mark_overflow();
      return;
    }
    const SphereNode& tn = q.tool_nodes[pair.tool];
    const SphereNode& on = q.object_nodes[pair.object];
    // A tool leaf whose quota is full reports nothing more for this object, nor a tool node whose
    // leaves are all capped: skip what is below.
    if (all_capped(q, pair.tool)) continue;
    if (quota_full(q, tn)) {
      leave_out(q, pair.tool, out);
      continue;
    }
    // Both leaves: only reached for the roots (pairs below are tested as they are generated).
    if (tn.is_leaf() && on.is_leaf()) {
      emit(q, pair.tool, pair.object, out);
      continue;
    }
    const bool split_tool =
        !tn.is_leaf() && (on.is_leaf() || q.tool_radii[pair.tool] >= static_cast<double>(on.radius));
    if (split_tool) q.placed->reach_children(pair.tool);
    const SphereNode& split = split_tool ? tn : on;
    const uint32_t end = split.first + split.count;
    // Children that still overlap, nearest first: leaf pairs are tested at once, the others wait on
    // the stack far-to-near, so that a tool leaf's quota fills with its nearest pairs first.
    std::array<DistPair, kMaxChildren> kids;
    int kid_count = 0;
    if (!split_tool && split.count <= kMaxChildren) {
      // An object node split against one tool node (most splits): the same tests, kept without a
      // branch on their outcome, which a descent through a tooth's small leaves cannot predict
      //. A tool leaf has no capsule, so that test's branch is predictable.
      const bool capsule = q.has_cap[pair.tool] != 0;
      for (uint32_t child = split.first; child < end; ++child) {
        const double d2 = distance2(q, pair.tool, child);
        const bool in_sphere = overlaps(q, pair.tool, child, d2);
        const bool in_capsule = !capsule || capsule_overlaps(q, pair.tool, child);
        kids[kid_count] = {d2, pair.tool, child};
        kid_count += static_cast<int>(in_sphere & in_capsule);
      }
    } else {
      for (uint32_t child = split.first; child < end; ++child) {
        const uint32_t t = split_tool ? child : pair.tool;
        const uint32_t o = split_tool ? pair.object : child;
        // A tool node whose leaves are all capped for this object needs no more tests.
        if (split_tool && all_capped(q, t)) continue;
        const double d2 = distance2(q, t, o);
        if (!overlaps(q, t, o, d2) || !capsule_overlaps(q, t, o)) continue;
        if (kid_count < static_cast<int>(kids.size())) {
          kids[kid_count++] = {d2, t, o};
        } else if (q.tool_nodes[t].is_leaf() && q.object_nodes[o].is_leaf()) {
          emit(q, t, o, out);  // more children than build_hierarchy makes: the rest unsorted
        } else if (top < kStackSize) {
          stack[top++] = {t, o};
        } else {
          out.mark_overflow();
        }
      }
    }
    sort_far_first(kids.data(), kid_count);
    for (int k = kid_count; k-- > 0;) {
      const DistPair& kid = kids[k];
      if (q.tool_nodes[kid.tool].is_leaf() && q.object_nodes[kid.object].is_leaf())
        emit(q, kid.tool, kid.object, out);
    }
    for (int k = 0; k < kid_count; ++k) {
      const DistPair& kid = kids[k];
      const SphereNode& kid_object = q.object_nodes[kid.object];
      if (q.tool_nodes[kid.tool].is_leaf() && kid_object.is_leaf()) continue;
      prefetch_children<2>(q.object_nodes, kid_object);
      if (top < kStackSize)
        stack[top++] = {kid.tool, kid.object};
      else
        out.mark_overflow();
    }
  }
}

}  // namespace

void collide(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask, ContactSet& out,
             uint32_t max_per_leaf, WorkBudget* budget) {
  ToolPlacement& p = tool.placement();
  const SphereTree& tree = *p.tool;
  if (tree.empty()) return;
  // Tool data shared by every object: the world copies as they are (a split moves what it reads).
  Query q{};
  q.placed = &p;
  q.tool_nodes = tree.nodes.data();
  q.tool_centers = p.centers.data();
  q.tool_radii = p.radii.data();
  q.leaf_margin = p.leaf_margin.data();
  q.cap_a = p.capsule_a.data();
  q.cap_d = p.capsule_d.data();
  q.cap_inv_dd = p.capsule_inv_dd.data();
  q.cap_r = p.capsule_radii.data();
  q.has_cap = p.has_capsule.data();
  q.hits = p.leaf_hits.data();
  q.caps = p.node_caps.data();
  q.parent = p.parent.data();
  q.leaves_below = p.leaves_below.data();
  q.max_per_leaf = max_per_leaf;
  q.leaf_quota = p.leaf_quota.size() == tree.leaf_count() ? p.leaf_quota.data() : nullptr;
  q.budget = budget;
  // One traversal per masked, non-empty object (the mask addresses the first 64).
  const std::size_t n = std::min<std::size_t>(objects.size(), 64);
  for (std::size_t i = 0; i < n; ++i) {
    if (((mask >> i) & 1u) == 0 || objects[i].tree.empty()) continue;
    q.object_nodes = objects[i].tree.nodes.data();
    q.object = static_cast<uint16_t>(i);
    q.skip_flags = objects[i].surface_only ? kLeafInterior : 0u;
    q.stamp = p.next_hit_stamp();
    traverse(q, out);
    if (budget != nullptr && budget->spent()) return;
  }
}

ContactGeometry contact_geometry(PlacedTool& tool, std::span<const CollisionObject> objects,
                                 const Contact& contact) {
  // Both centres in the world; a direction is undefined below kCoincident, then the tool's axis.
  const SphereNode& on = objects[contact.object].tree.nodes[contact.object_node];
  ToolPlacement& p = tool.placement();
  const Vec3 c_t = p.center(p.tool->leaf_nodes[contact.tool_leaf]);
  const Vec3 c_o = on.center.cast<double>();
  const Vec3 d = c_t - c_o;
  const double dist = d.norm();
  Vec3 fallback = p.pose.z_axis();
  if (!fallback.allFinite() || fallback.squaredNorm() < 0.5) fallback = Vec3::UnitZ();
  ContactGeometry out;
  out.normal = dist > kCoincident ? Vec3(d / dist) : fallback;
  out.point = c_o + out.normal * static_cast<double>(on.radius);
  out.lever = c_t - p.pose.p;
  return out;
}

void sphere_collide(const Vec3& center, double radius, uint16_t tool_leaf, uint16_t object_index,
                    const CollisionObject& object, double margin_mm, ContactSet& out, WorkBudget* budget) {
  if (object.tree.empty() || !(margin_mm > -std::numeric_limits<double>::infinity())) return;
  const SphereNode* nodes = object.tree.nodes.data();
  const uint32_t skip = object.surface_only ? kLeafInterior : 0u;
  const auto gap = [&](uint32_t o) {
    return (center - nodes[o].center.cast<double>()).norm() - radius - static_cast<double>(nodes[o].radius);
  };
  std::array<uint32_t, kStackSize> stack;
  int top = 0;
  if (gap(0) < margin_mm + kPruneSlack) stack[top++] = 0;
  while (top > 0) {
    const uint32_t o = stack[--top];
    if (budget != nullptr && !budget->take()) {
      out.mark_overflow();
      return;
    }
    const SphereNode& n = nodes[o];
    if (n.is_leaf()) {
      const double g = gap(o);
      if ((n.flags & skip) || !(g < margin_mm)) continue;
      if (budget != nullptr) budget->charge(kContactWork);
      Contact c;
      c.gap = g;
      c.object_node = o;
      c.tool_leaf = tool_leaf;
      c.object = object_index;
      c.material = n.material;
      out.push(c);
      continue;
    }
    for (uint32_t ch = n.first; ch < n.first + n.count; ++ch) {
      if (!(gap(ch) < margin_mm + kPruneSlack)) continue;
      if (top < kStackSize)
        stack[top++] = ch;
      else
        out.mark_overflow();
    }
  }
}

}  // namespace cariesim
