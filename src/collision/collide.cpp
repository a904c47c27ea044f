#include "cariesim/collision/collide.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim {

// The queries' view of a placement: the world copies as they are, without moving what is left
// (PlacedTool's accessors move everything first). A query moves a tool node's children with
// reach_children() before it reads them.
struct PlacedToolNodes {
  static const Vec3* centers(const PlacedTool& t) { return t.centers_.data(); }
  static const Vec3* capsule_a(const PlacedTool& t) { return t.capsule_a_.data(); }
  static const Vec3* capsule_d(const PlacedTool& t) { return t.capsule_d_.data(); }
  static const double* capsule_radii(const PlacedTool& t) { return t.capsule_radii_.data(); }
  static const double* radii(const PlacedTool& t) { return t.radii_.data(); }
  static const double* leaf_margins(const PlacedTool& t) { return t.leaf_margin_.data(); }
  // The world centre of one node, moving it (with its siblings) first when it is not yet.
  static const Vec3& center(const PlacedTool& t, uint32_t node) {
    const uint32_t parent = t.parent_[node];
    if (parent != node) t.reach_children(parent);
    return t.centers_[node];
  }
};

namespace {

// Pending node pairs of a dual traversal. Depth first, each split pushes at most 7 siblings that wait
// while the first is explored, so a stack of this size holds any pair of trees whose levels sum to
// 146 or less (balanced trees of 10^6 leaves have about 10 levels each).
constexpr int kStackSize = 1024;
// mm; node pairs are kept when they overlap within this slack, so rounding never prunes a pair.
constexpr double kPruneSlack = 1e-6;
// mm; below this centre distance the direction between two spheres is taken as undefined.
constexpr double kCoincident = 1e-12;

struct NodePair {
  uint32_t tool;
  uint32_t object;
};

// Everything the traversal of one object reads, as raw pointers (no bounds checks in the hot loop).
struct Query {
  const PlacedTool* placed;        // moves a tool node's children before they are read
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
  PlacedTool::LeafHits* hits;    // per tool leaf: pairs reported for this object (stamped)
  PlacedTool::LeafHits* caps;    // per tool node: leaves below it capped for this object (stamped)
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
  const PlacedTool::LeafHits& hits = q.hits[tool_node.leaf];
  return tool_node.is_leaf() && hits.stamp == q.stamp && hits.count >= quota(q, tool_node.leaf);
}

// True when every leaf below tool node t (t itself for a leaf) has left out a pair for the object
// being traversed (is capped): nothing more below t need be tested.
inline bool all_capped(const Query& q, uint32_t t) {
  const PlacedTool::LeafHits& caps = q.caps[t];
  return caps.stamp == q.stamp && caps.count >= q.leaves_below[t];
}

// A pair of tool leaf node t whose quota is full is left out: the first time, note the combination
// (the count goes one past the quota to remember it) and count the leaf as capped in every ancestor.
inline void leave_out(const Query& q, uint32_t t, ContactSet& out) {
  const uint32_t leaf = q.tool_nodes[t].leaf;
  PlacedTool::LeafHits& hits = q.hits[leaf];
  if (hits.count != quota(q, leaf)) return;
  ++hits.count;
  out.note_capped(static_cast<uint16_t>(leaf), q.object);
  for (uint32_t n = t;; n = q.parent[n]) {
    PlacedTool::LeafHits& caps = q.caps[n];
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

// Fetches the first `lines` cache lines (two 32-byte nodes each) of an inner node's children, which
// will be read when the node waiting on a stack is split. A scanned tooth's tree is megabytes, and
// the hottest instruction of the traversal's profile waited on a child's centre (issue #11). The
// dual traversal fetches two lines, the single sphere's search one: what each was measured with.
template <int lines>
[[gnu::always_inline]] inline void prefetch_children(const SphereNode* nodes, const SphereNode& node) {
  static_assert(lines == 1 || lines == 2);
  if (node.is_leaf()) return;
  const SphereNode* children = nodes + node.first;
  __builtin_prefetch(children);
  if (lines == 2 && node.count > 2) __builtin_prefetch(children + 2);
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
  PlacedTool::LeafHits& hits = q.hits[tn.leaf];
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
      // (issue #11). A tool leaf has no capsule, so that test's branch is predictable.
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

// A pair waiting in the closest-pair search, with the lower bound of its gap.
struct BoundedPair {
  double bound;  // mm
  uint32_t tool;
  uint32_t object;
};

// Lower bound of the gap between any leaves under a tool node and an object node (true radii);
// the exact gap for two leaves.
inline double gap_bound(const Vec3* tool_centers, const SphereNode* tool_nodes, const SphereNode* object_nodes,
                        uint32_t t, uint32_t o) {
  const SphereNode& on = object_nodes[o];
  return (tool_centers[t] - on.center.cast<double>()).norm() - static_cast<double>(tool_nodes[t].radius) -
         static_cast<double>(on.radius);
}

}  // namespace

PlacedTool::PlacedTool(const SphereTree& tool) : tool_(&tool) {
  // place() fits inner spheres in one reverse sweep, which needs every child after its parent.
  for (std::size_t i = 0; i < tool.nodes.size(); ++i) {
    const SphereNode& n = tool.nodes[i];
    if (!n.is_leaf() && (n.first <= i || n.first + n.count > tool.nodes.size())) {
      throw Error("PlacedTool: tool tree node " + std::to_string(i) +
                  " has children that do not follow it in the node array");
    }
    if (n.is_leaf() && n.leaf >= tool.leaf_count()) {
      throw Error("PlacedTool: tool tree leaf node " + std::to_string(i) + " has leaf index " +
                  std::to_string(n.leaf) + " beyond the leaf table");
    }
  }
  if (tool.leaf_count() > std::numeric_limits<uint16_t>::max()) {
    throw Error("PlacedTool: " + std::to_string(tool.leaf_count()) +
                " tool leaves exceed the contact's 16-bit leaf index");
  }
  centers_.assign(tool.nodes.size(), Vec3::Zero());
  children_placed_.assign(tool.nodes.size(), 0u);
  radii_.assign(tool.nodes.size(), 0.0);
  leaf_margin_.assign(tool.leaf_count(), 0.0);
  leaf_hits_.assign(tool.leaf_count(), LeafHits{});
  node_caps_.assign(tool.nodes.size(), LeafHits{});
  // Parents and leaf counts (children follow their parent, so one reverse sweep sums them).
  parent_.assign(tool.nodes.size(), 0);
  leaves_below_.assign(tool.nodes.size(), 0);
  for (std::size_t i = 0; i < tool.nodes.size(); ++i) {
    const SphereNode& n = tool.nodes[i];
    for (uint32_t c = n.first; c < n.first + n.count; ++c) parent_[c] = static_cast<uint32_t>(i);
  }
  max_reach_.assign(tool.nodes.size(), 0.0);
  for (std::size_t i = tool.nodes.size(); i-- > 0;) {
    const SphereNode& n = tool.nodes[i];
    if (n.is_leaf()) {
      leaves_below_[i] = 1;
      max_reach_[i] = n.center.cast<double>().norm();
    }
    for (uint32_t c = n.first; c < n.first + n.count; ++c) {
      leaves_below_[i] += leaves_below_[c];
      max_reach_[i] = std::max(max_reach_[i], max_reach_[c]);
    }
  }
  fit_capsules();
}

namespace {
// A capsule is kept where its radius is below this fraction of the node's sphere radius.
constexpr double kCapsuleGain = 0.8;
}  // namespace

void PlacedTool::fit_capsules() {
  const std::vector<SphereNode>& nodes = tool_->nodes;
  const std::size_t n = nodes.size();
  tool_capsule_a_.assign(n, Vec3::Zero());
  tool_capsule_d_.assign(n, Vec3::Zero());
  tool_capsule_radius_.assign(n, 0.0);
  capsule_a_.assign(n, Vec3::Zero());
  capsule_d_.assign(n, Vec3::Zero());
  capsule_inv_dd_.assign(n, 0.0);
  capsule_radii_.assign(n, 0.0);
  has_capsule_.assign(n, 0);
  std::vector<uint32_t> leaves;
  std::vector<uint32_t> pending;
  for (std::size_t i = 0; i < n; ++i) {
    if (nodes[i].is_leaf()) continue;
    // The leaves below node i.
    leaves.clear();
    pending.assign(1, static_cast<uint32_t>(i));
    while (!pending.empty()) {
      const uint32_t k = pending.back();
      pending.pop_back();
      if (nodes[k].is_leaf()) {
        leaves.push_back(k);
        continue;
      }
      for (uint32_t c = nodes[k].first; c < nodes[k].first + nodes[k].count; ++c) pending.push_back(c);
    }
    // Their centres' principal axis through their mean; the segment spans their projections, so each
    // centre's distance to it is its distance to the axis.
    Vec3 mean = Vec3::Zero();
    for (uint32_t k : leaves) mean += nodes[k].center.cast<double>();
    mean /= static_cast<double>(leaves.size());
    Mat3 cov = Mat3::Zero();
    for (uint32_t k : leaves) {
      const Vec3 c = nodes[k].center.cast<double>() - mean;
      cov += c * c.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Mat3> eigen(cov);
    const Vec3 axis = eigen.eigenvectors().col(2).normalized();  // largest eigenvalue last
    if (!axis.allFinite()) continue;
    double t_min = std::numeric_limits<double>::infinity();
    double t_max = -t_min;
    for (uint32_t k : leaves) {
      const double t = axis.dot(nodes[k].center.cast<double>() - mean);
      t_min = std::min(t_min, t);
      t_max = std::max(t_max, t);
    }
    double radius = 0.0;  // mm
    for (uint32_t k : leaves) {
      const Vec3 c = nodes[k].center.cast<double>() - mean;
      const double off_axis = (c - axis.dot(c) * axis).norm();
      radius = std::max(radius, off_axis + static_cast<double>(nodes[k].radius));
    }
    if (!(radius < kCapsuleGain * static_cast<double>(nodes[i].radius))) continue;
    has_capsule_[i] = 1;
    tool_capsule_a_[i] = mean + t_min * axis;
    tool_capsule_d_[i] = (t_max - t_min) * axis;
    const double dd = tool_capsule_d_[i].squaredNorm();
    capsule_inv_dd_[i] = dd > 1e-18 ? 1.0 / dd : 0.0;
    tool_capsule_radius_[i] = radius;
  }
}

[[gnu::flatten]] void PlacedTool::place_node(std::size_t i) const {
  const SphereNode& n = tool_->nodes[i];
  centers_[i] = pose_.p + rot_ * n.center.cast<double>();
  if (reach_margins_) {
    const double margin = margins_.at(max_reach_[i]);
    radii_[i] = static_cast<double>(n.radius) + margin;
    if (n.is_leaf()) leaf_margin_[n.leaf] = margin;
  }
  if (has_capsule_[i] == 0) return;
  capsule_a_[i] = pose_.p + rot_ * tool_capsule_a_[i];
  capsule_d_[i] = rot_ * tool_capsule_d_[i];
  // Grown like the node's sphere: by the largest margin of the leaves below.
  capsule_radii_[i] = tool_capsule_radius_[i] + (radii_[i] - static_cast<double>(n.radius));
}

void PlacedTool::place_children(uint32_t node) const {
  const SphereNode& n = tool_->nodes[node];
  for (uint32_t c = n.first; c < n.first + n.count; ++c) place_node(c);
  children_placed_[node] = place_stamp_;
}

void PlacedTool::start_placement(const Pose& pose) {
  pose_ = pose;
  rot_ = pose.q.toRotationMatrix();
  // Stamps tell this placement's moved nodes from older ones without clearing the table each time.
  if (++place_stamp_ == 0) {
    std::fill(children_placed_.begin(), children_placed_.end(), 0u);
    place_stamp_ = 1;
  }
}

void PlacedTool::place(const Pose& pose, const ReachMargins& margins) {
  start_placement(pose);
  reach_margins_ = true;
  margins_ = margins;
  if (!tool_->nodes.empty()) place_node(0);
}

void PlacedTool::place_all() const {
  if (tool_->nodes.empty()) return;
  for (uint32_t i = 0; i < tool_->nodes.size(); ++i)
    if (!tool_->nodes[i].is_leaf()) reach_children(i);
}

uint32_t PlacedTool::next_hit_stamp() const {
  // Stamps tell one traversal's counters from older ones without clearing the table each time.
  if (++hit_stamp_ == 0) {
    std::fill(leaf_hits_.begin(), leaf_hits_.end(), LeafHits{});
    std::fill(node_caps_.begin(), node_caps_.end(), LeafHits{});
    hit_stamp_ = 1;
  }
  return hit_stamp_;
}

void PlacedTool::place(const Pose& pose, double margin) {
  start_placement(pose);
  reach_margins_ = false;
  // One margin for every leaf (negative or non-finite counts as zero): every node, leaf or inner,
  // grows by exactly that much.
  const double m = std::isfinite(margin) ? std::max(margin, 0.0) : 0.0;
  std::fill(leaf_margin_.begin(), leaf_margin_.end(), m);
  const std::vector<SphereNode>& nodes = tool_->nodes;
  for (std::size_t i = 0; i < nodes.size(); ++i) radii_[i] = static_cast<double>(nodes[i].radius) + m;
  if (!nodes.empty()) place_node(0);
}

void PlacedTool::place(const Pose& pose, std::span<const double> leaf_margin) {
  assert((leaf_margin.empty() || leaf_margin.size() == leaf_margin_.size()) && "one margin per tool leaf");
  // Per-leaf margins (an empty table keeps the ones already set); bad values count as zero.
  const std::size_t given = std::min(leaf_margin.size(), leaf_margin_.size());
  if (reach_margins_ && given < leaf_margin_.size()) place_all();  // the margins to keep
  start_placement(pose);
  reach_margins_ = false;
  for (std::size_t i = 0; i < given; ++i) {
    const double m = leaf_margin[i];
    leaf_margin_[i] = std::isfinite(m) ? std::max(m, 0.0) : 0.0;
  }
  // Leaves grow by their margin; inner spheres by the largest inflation below them (children come
  // after their parent, so one reverse sweep sees every child first).
  const std::vector<SphereNode>& nodes = tool_->nodes;
  for (std::size_t i = nodes.size(); i-- > 0;) {
    const SphereNode& n = nodes[i];
    if (n.is_leaf()) {
      radii_[i] = static_cast<double>(n.radius) + leaf_margin_[n.leaf];
      continue;
    }
    double inflation = 0.0;
    for (uint32_t k = n.first; k < n.first + n.count; ++k) {
      inflation = std::max(inflation, radii_[k] - static_cast<double>(nodes[k].radius));
    }
    radii_[i] = static_cast<double>(n.radius) + inflation;
  }
  if (!nodes.empty()) place_node(0);
}

void collide(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
             ContactSet& out, uint32_t max_per_leaf, WorkBudget* budget) {
  const SphereTree& tree = tool.tree();
  if (tree.empty()) return;
  // Tool data shared by every object.
  Query q{};
  q.placed = &tool;
  q.tool_nodes = tree.nodes.data();
  q.tool_centers = PlacedToolNodes::centers(tool);
  q.tool_radii = PlacedToolNodes::radii(tool);
  q.leaf_margin = PlacedToolNodes::leaf_margins(tool);
  q.cap_a = PlacedToolNodes::capsule_a(tool);
  q.cap_d = PlacedToolNodes::capsule_d(tool);
  q.cap_inv_dd = tool.capsule_inv_dd().data();
  q.cap_r = PlacedToolNodes::capsule_radii(tool);
  q.has_cap = tool.has_capsule().data();
  q.hits = tool.leaf_hits().data();
  q.caps = tool.node_caps().data();
  q.parent = tool.parents().data();
  q.leaves_below = tool.leaves_below().data();
  q.max_per_leaf = max_per_leaf;
  q.leaf_quota = tool.leaf_quota().size() == tree.leaf_count() ? tool.leaf_quota().data() : nullptr;
  q.budget = budget;
  // One traversal per masked, non-empty object (the mask addresses the first 64).
  const std::size_t n = std::min<std::size_t>(objects.size(), 64);
  for (std::size_t i = 0; i < n; ++i) {
    if (((mask >> i) & 1u) == 0 || objects[i].tree.empty()) continue;
    q.object_nodes = objects[i].tree.nodes.data();
    q.object = static_cast<uint16_t>(i);
    q.skip_flags = objects[i].surface_only ? kLeafInterior : 0u;
    q.stamp = tool.next_hit_stamp();
    traverse(q, out);
    if (budget != nullptr && budget->spent()) return;
  }
}

ContactGeometry contact_geometry(const PlacedTool& tool, std::span<const CollisionObject> objects,
                                 const Contact& contact) {
  // Both centres in the world; a direction is undefined below kCoincident, then the tool's axis.
  const SphereNode& on = objects[contact.object].tree.nodes[contact.object_node];
  const Vec3 c_t = PlacedToolNodes::center(tool, tool.tree().leaf_nodes[contact.tool_leaf]);
  const Vec3 c_o = on.center.cast<double>();
  const Vec3 d = c_t - c_o;
  const double dist = d.norm();
  Vec3 fallback = tool.pose().z_axis();
  if (!fallback.allFinite() || fallback.squaredNorm() < 0.5) fallback = Vec3::UnitZ();
  ContactGeometry out;
  out.normal = dist > kCoincident ? Vec3(d / dist) : fallback;
  out.point = c_o + out.normal * static_cast<double>(on.radius);
  out.lever = c_t - tool.pose().p;
  return out;
}

namespace {

// Branch and bound over the tool and the masked objects' trees (closest() and any_within()): with
// `first`, returns at the first leaf pair within the search radius.
ClosestPair bounded_search(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                           double search_mm, WorkBudget* budget, bool first) {
  ClosestPair best;
  best.gap = std::numeric_limits<double>::infinity();
  const SphereTree& tree = tool.tree();
  if (tree.empty() || std::isnan(search_mm)) return best;
  const SphereNode* tn = tree.nodes.data();
  const Vec3* tc = PlacedToolNodes::centers(tool);  // a split tool node's children are moved first
  // Branch and bound: a pair is explored only while its lower bound beats the best gap so far
  // (initially the search radius); children are pushed far-to-near so the nearest is explored first.
  double bound_limit = search_mm;
  std::array<BoundedPair, kStackSize> stack;
  const std::size_t n = std::min<std::size_t>(objects.size(), 64);
  for (std::size_t i = 0; i < n; ++i) {
    if (((mask >> i) & 1u) == 0 || objects[i].tree.empty()) continue;
    const SphereNode* on = objects[i].tree.nodes.data();
    int top = 0;
    stack[top++] = {gap_bound(tc, tn, on, 0, 0), 0, 0};
    while (top > 0) {
      const BoundedPair pair = stack[--top];
      if (!(pair.bound < bound_limit)) continue;
      if (budget != nullptr && !budget->take()) {
        best.complete = false;
        return best;
      }
      const SphereNode& a = tn[pair.tool];
      const SphereNode& b = on[pair.object];
      // Two leaves: the bound is the exact gap.
      if (a.is_leaf() && b.is_leaf()) {
        bound_limit = pair.bound;
        best = {pair.bound, static_cast<uint16_t>(a.leaf), static_cast<uint16_t>(i), pair.object};
        if (first) return best;
        continue;
      }
      // Split the larger sphere; keep the children that can still beat the best gap.
      const bool split_tool = !a.is_leaf() && (b.is_leaf() || a.radius >= b.radius);
      if (split_tool) tool.reach_children(pair.tool);
      const SphereNode& split = split_tool ? a : b;
      std::array<BoundedPair, 8> kids;
      int kid_count = 0;
      for (uint32_t c = split.first; c < split.first + split.count; ++c) {
        const uint32_t t = split_tool ? c : pair.tool;
        const uint32_t o = split_tool ? pair.object : c;
        const double lb = gap_bound(tc, tn, on, t, o);
        if (!(lb < bound_limit)) continue;
        if (kid_count < static_cast<int>(kids.size())) {
          kids[kid_count++] = {lb, t, o};
        } else if (top < kStackSize) {
          stack[top++] = {lb, t, o};  // more than 8 children: the rest go unsorted
        }
      }
      // At most 8 children: an insertion sort, far first.
      for (int k = 1; k < kid_count; ++k) {
        const BoundedPair moving = kids[k];
        int j = k;
        for (; j > 0 && kids[j - 1].bound < moving.bound; --j) kids[j] = kids[j - 1];
        kids[j] = moving;
      }
      for (int k = 0; k < kid_count && top < kStackSize; ++k) stack[top++] = kids[k];
    }
  }
  return best;
}

}  // namespace

ClosestPair closest(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                    double search_mm, WorkBudget* budget) {
  return bounded_search(tool, objects, mask, search_mm, budget, false);
}

ClosestPair any_within(const PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                       double search_mm, WorkBudget* budget) {
  return bounded_search(tool, objects, mask, search_mm, budget, true);
}

double sphere_closest(const Vec3& center, double radius, const CollisionObject& object, double search_mm,
                      WorkBudget* budget) {
  double best = std::numeric_limits<double>::infinity();
  if (object.tree.empty() || std::isnan(search_mm)) return best;
  const SphereNode* nodes = object.tree.nodes.data();
  const uint32_t skip = object.surface_only ? kLeafInterior : 0u;
  double limit = search_mm;
  const auto bound = [&](uint32_t o) {
    return (center - nodes[o].center.cast<double>()).norm() - radius - static_cast<double>(nodes[o].radius);
  };
  // Depth first, branch and bound on the gap's lower bound.
  std::array<uint32_t, kStackSize> stack;
  int top = 0;
  if (bound(0) < limit) stack[top++] = 0;
  while (top > 0) {
    const uint32_t o = stack[--top];
    if (budget != nullptr && !budget->take()) return -std::numeric_limits<double>::infinity();
    const SphereNode& n = nodes[o];
    if (n.is_leaf()) {
      const double gap = bound(o);
      if (!(n.flags & skip) && gap < limit) best = limit = gap;
      continue;
    }
    for (uint32_t c = n.first; c < n.first + n.count; ++c) {
      if (!(bound(c) < limit && top < kStackSize)) continue;
      stack[top++] = c;
      prefetch_children<1>(nodes, nodes[c]);
    }
  }
  return best;
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
