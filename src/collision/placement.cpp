// Tool placement: the tool tree's tables fitted once (parents, leaves below, reach, capsules), and
// the lazy placement of its nodes in the world for the queries (placement.hpp). PlacedTool, the
// public handle, forwards to it.
#include "collision/placement.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim {
namespace collision_detail {

ToolPlacement::ToolPlacement(const SphereTree& tree) : tool(&tree) {
  // place() fits inner spheres in one reverse sweep, which needs every child after its parent.
  for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
    const SphereNode& n = tree.nodes[i];
    if (!n.is_leaf() && (n.first <= i || n.first + n.count > tree.nodes.size())) {
      throw Error("PlacedTool: tool tree node " + std::to_string(i) +
                  " has children that do not follow it in the node array");
    }
    if (n.is_leaf() && n.leaf >= tree.leaf_count()) {
      throw Error("PlacedTool: tool tree leaf node " + std::to_string(i) + " has leaf index " +
                  std::to_string(n.leaf) + " beyond the leaf table");
    }
  }
  if (tree.leaf_count() > std::numeric_limits<uint16_t>::max()) {
    throw Error("PlacedTool: " + std::to_string(tree.leaf_count()) +
                " tool leaves exceed the contact's 16-bit leaf index");
  }
  centers.assign(tree.nodes.size(), Vec3::Zero());
  children_placed.assign(tree.nodes.size(), 0u);
  radii.assign(tree.nodes.size(), 0.0);
  leaf_margin.assign(tree.leaf_count(), 0.0);
  leaf_hits.assign(tree.leaf_count(), LeafHits{});
  node_caps.assign(tree.nodes.size(), LeafHits{});
  // Parents and leaf counts (children follow their parent, so one reverse sweep sums them).
  parent.assign(tree.nodes.size(), 0);
  leaves_below.assign(tree.nodes.size(), 0);
  for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
    const SphereNode& n = tree.nodes[i];
    for (uint32_t c = n.first; c < n.first + n.count; ++c) parent[c] = static_cast<uint32_t>(i);
  }
  max_reach.assign(tree.nodes.size(), 0.0);
  for (std::size_t i = tree.nodes.size(); i-- > 0;) {
    const SphereNode& n = tree.nodes[i];
    if (n.is_leaf()) {
      leaves_below[i] = 1;
      max_reach[i] = n.center.cast<double>().norm();
    }
    for (uint32_t c = n.first; c < n.first + n.count; ++c) {
      leaves_below[i] += leaves_below[c];
      max_reach[i] = std::max(max_reach[i], max_reach[c]);
    }
  }
  fit_capsules();
}

namespace {
// A capsule is kept where its radius is below this fraction of the node's sphere radius.
constexpr double kCapsuleGain = 0.8;
}  // namespace

void ToolPlacement::fit_capsules() {
  const std::vector<SphereNode>& nodes = tool->nodes;
  const std::size_t n = nodes.size();
  tool_capsule_a.assign(n, Vec3::Zero());
  tool_capsule_d.assign(n, Vec3::Zero());
  tool_capsule_radius.assign(n, 0.0);
  capsule_a.assign(n, Vec3::Zero());
  capsule_d.assign(n, Vec3::Zero());
  capsule_inv_dd.assign(n, 0.0);
  capsule_radii.assign(n, 0.0);
  has_capsule.assign(n, 0);
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
    has_capsule[i] = 1;
    tool_capsule_a[i] = mean + t_min * axis;
    tool_capsule_d[i] = (t_max - t_min) * axis;
    const double dd = tool_capsule_d[i].squaredNorm();
    capsule_inv_dd[i] = dd > 1e-18 ? 1.0 / dd : 0.0;
    tool_capsule_radius[i] = radius;
  }
}

[[gnu::flatten]] void ToolPlacement::place_node(std::size_t i) {
  const SphereNode& n = tool->nodes[i];
  centers[i] = pose.p + rot * n.center.cast<double>();
  if (reach_margins) {
    const double margin = margins.at(max_reach[i]);
    radii[i] = static_cast<double>(n.radius) + margin;
    if (n.is_leaf()) leaf_margin[n.leaf] = margin;
  }
  if (has_capsule[i] == 0) return;
  capsule_a[i] = pose.p + rot * tool_capsule_a[i];
  capsule_d[i] = rot * tool_capsule_d[i];
  // Grown like the node's sphere: by the largest margin of the leaves below.
  capsule_radii[i] = tool_capsule_radius[i] + (radii[i] - static_cast<double>(n.radius));
}

void ToolPlacement::place_children(uint32_t node) {
  const SphereNode& n = tool->nodes[node];
  for (uint32_t c = n.first; c < n.first + n.count; ++c) place_node(c);
  children_placed[node] = place_stamp;
}

void ToolPlacement::start_placement(const Pose& at) {
  pose = at;
  rot = at.q.toRotationMatrix();
  // Stamps tell this placement's moved nodes from older ones without clearing the table each time.
  if (++place_stamp == 0) {
    std::fill(children_placed.begin(), children_placed.end(), 0u);
    place_stamp = 1;
  }
}

void ToolPlacement::place(const Pose& at, const ReachMargins& rule) {
  start_placement(at);
  reach_margins = true;
  margins = rule;
  if (!tool->nodes.empty()) place_node(0);
}

void ToolPlacement::place_all() {
  if (tool->nodes.empty()) return;
  for (uint32_t i = 0; i < tool->nodes.size(); ++i)
    if (!tool->nodes[i].is_leaf()) reach_children(i);
}

uint32_t ToolPlacement::next_hit_stamp() {
  // Stamps tell one traversal's counters from older ones without clearing the table each time.
  if (++hit_stamp == 0) {
    std::fill(leaf_hits.begin(), leaf_hits.end(), LeafHits{});
    std::fill(node_caps.begin(), node_caps.end(), LeafHits{});
    hit_stamp = 1;
  }
  return hit_stamp;
}

void ToolPlacement::place(const Pose& at, double margin) {
  start_placement(at);
  reach_margins = false;
  // One margin for every leaf (negative or non-finite counts as zero): every node, leaf or inner,
  // grows by exactly that much.
  const double m = std::isfinite(margin) ? std::max(margin, 0.0) : 0.0;
  std::fill(leaf_margin.begin(), leaf_margin.end(), m);
  const std::vector<SphereNode>& nodes = tool->nodes;
  for (std::size_t i = 0; i < nodes.size(); ++i) radii[i] = static_cast<double>(nodes[i].radius) + m;
  if (!nodes.empty()) place_node(0);
}

void ToolPlacement::place(const Pose& at, std::span<const double> margin_per_leaf) {
  assert((margin_per_leaf.empty() || margin_per_leaf.size() == leaf_margin.size()) &&
         "one margin per tool leaf");
  // Per-leaf margins (an empty table keeps the ones already set); bad values count as zero.
  const std::size_t given = std::min(margin_per_leaf.size(), leaf_margin.size());
  if (reach_margins && given < leaf_margin.size()) place_all();  // the margins to keep
  start_placement(at);
  reach_margins = false;
  for (std::size_t i = 0; i < given; ++i) {
    const double m = margin_per_leaf[i];
    leaf_margin[i] = std::isfinite(m) ? std::max(m, 0.0) : 0.0;
  }
  // Leaves grow by their margin; inner spheres by the largest inflation below them (children come
  // after their parent, so one reverse sweep sees every child first).
  const std::vector<SphereNode>& nodes = tool->nodes;
  for (std::size_t i = nodes.size(); i-- > 0;) {
    const SphereNode& n = nodes[i];
    if (n.is_leaf()) {
      radii[i] = static_cast<double>(n.radius) + leaf_margin[n.leaf];
      continue;
    }
    double inflation = 0.0;
    for (uint32_t k = n.first; k < n.first + n.count; ++k) {
      inflation = std::max(inflation, radii[k] - static_cast<double>(nodes[k].radius));
    }
    radii[i] = static_cast<double>(n.radius) + inflation;
  }
  if (!nodes.empty()) place_node(0);
}

}  // namespace collision_detail

// PlacedTool: the public handle of a ToolPlacement.

PlacedTool::PlacedTool(const SphereTree& tool)
    : placement_(std::make_unique<collision_detail::ToolPlacement>(tool)) {}
PlacedTool::~PlacedTool() = default;
PlacedTool::PlacedTool(PlacedTool&&) noexcept = default;
PlacedTool& PlacedTool::operator=(PlacedTool&&) noexcept = default;

void PlacedTool::place(const Pose& pose, double margin) { placement_->place(pose, margin); }
void PlacedTool::place(const Pose& pose, std::span<const double> leaf_margin) {
  placement_->place(pose, leaf_margin);
}
void PlacedTool::place(const Pose& pose, const ReachMargins& margins) { placement_->place(pose, margins); }
const SphereTree& PlacedTool::tree() const { return *placement_->tool; }
const Pose& PlacedTool::pose() const { return placement_->pose; }

// The world copies, whole: what no query has reached yet is moved first.
std::span<const Vec3> PlacedTool::centers() {
  placement_->place_all();
  return placement_->centers;
}
std::span<const double> PlacedTool::radii() {
  placement_->place_all();
  return placement_->radii;
}
std::span<const double> PlacedTool::leaf_margins() {
  placement_->place_all();
  return placement_->leaf_margin;
}
std::span<const Vec3> PlacedTool::capsule_a() {
  placement_->place_all();
  return placement_->capsule_a;
}
std::span<const Vec3> PlacedTool::capsule_d() {
  placement_->place_all();
  return placement_->capsule_d;
}
std::span<const double> PlacedTool::capsule_radii() {
  placement_->place_all();
  return placement_->capsule_radii;
}
std::span<const uint8_t> PlacedTool::has_capsule() const { return placement_->has_capsule; }

void PlacedTool::set_leaf_quota(std::span<const uint32_t> quota) {
  placement_->leaf_quota.assign(quota.begin(), quota.end());
}
std::span<const uint32_t> PlacedTool::leaf_quota() const { return placement_->leaf_quota; }

}  // namespace cariesim
