// Surface deviation of a sphere tree (docs/design.md §3) and its structural check.

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/build.hpp"
#include "spheretree/build_support.hpp"

namespace cariesim {

namespace {

// min over leaves of |x - c| - r, by branch and bound: |x - c| - r of a node bounds that of every
// leaf inside it, so subtrees that cannot beat the best leaf so far are skipped; nearer children
// are visited first.
double distance_to_union(const SphereTree& tree, const Vec3f& x, std::vector<uint32_t>& stack) {
  double best = std::numeric_limits<double>::infinity();
  stack.clear();
  stack.push_back(0);
  std::array<std::pair<float, uint32_t>, 8> children{};
  while (!stack.empty()) {
    const SphereNode& node = tree.nodes[stack.back()];
    stack.pop_back();
    const double bound = double((x - node.center).norm()) - node.radius;
    if (bound >= best) continue;
    if (node.is_leaf()) {
      best = bound;
      continue;
    }
    // Push the children far-to-near so that the nearest is popped first (unsorted for a node with
    // more than 8 children, which no builder makes).
    const int count = node.count;
    if (count > 8) {
      for (int k = 0; k < count; ++k) stack.push_back(node.first + static_cast<uint32_t>(k));
      continue;
    }
    int n = 0;
    for (int k = 0; k < count; ++k) {
      const SphereNode& child = tree.nodes[node.first + k];
      const float b = (x - child.center).norm() - child.radius;
      if (b < best) children[n++] = {b, node.first + static_cast<uint32_t>(k)};
    }
    for (int a = 1; a < n; ++a) {
      for (int b = a; b > 0 && children[b - 1].first < children[b].first; --b)
        std::swap(children[b - 1], children[b]);
    }
    for (int k = 0; k < n; ++k) stack.push_back(children[k].second);
  }
  return best;
}

// The q-quantile (0..1) of values (reorders them).
double quantile(std::vector<double>& values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(
      std::min<double>(q * static_cast<double>(values.size() - 1), static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// Pools |sample distance| with the positive poke-outs, then the percentiles.
Deviation pooled(const std::vector<double>& to_union, const std::vector<double>& poke) {
  Deviation dev;
  dev.samples = to_union.size();
  std::vector<double> pool;
  pool.reserve(to_union.size() + poke.size());
  for (double d : to_union) {
    pool.push_back(std::abs(d));
    dev.max_fall_short = std::max(dev.max_fall_short, d);
    dev.max_poke_out = std::max(dev.max_poke_out, -d);
  }
  for (double p : poke) {
    if (p > 0.0) {
      pool.push_back(p);
      dev.max_poke_out = std::max(dev.max_poke_out, p);
    }
  }
  if (pool.empty()) return dev;
  dev.max = *std::max_element(pool.begin(), pool.end());
  dev.p95 = quantile(pool, 0.95);
  dev.p50 = quantile(pool, 0.50);
  return dev;
}

}  // namespace

Deviation measure_deviation(const SphereTree& tree, const TriangleMesh& surface, const LevelSet& shape,
                            std::size_t samples, uint64_t seed) {
  if (tree.empty() || tree.leaf_nodes.empty()) throw Error("measure_deviation: the tree has no leaves");
  if (surface.triangles.empty()) throw Error("measure_deviation: the surface mesh has no triangles");
  if (shape.empty()) throw Error("measure_deviation: the level set is empty");
  if (samples == 0) throw Error("measure_deviation: at least one surface sample is needed");

  // Surface side: distance from each sample to the union of leaves (parallel, read-only tree).
  const std::vector<Vec3> points = detail::sample_surface(surface, samples, seed);
  std::vector<double> to_union(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<uint32_t> stack;
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        to_union[i] = distance_to_union(tree, points[i].cast<float>(), stack);
                      }
                    });

  // Leaf side: how far each leaf reaches beyond the surface, r + D(c), for every leaf whose centre
  // lies where the narrow band resolves D. A leaf centred deeper can only poke out if it is larger
  // than the band, and then it swallows surface samples, which the sample side above measures.
  const detail::DistanceField field(shape, 0.0, 0.0);
  std::vector<double> poke(tree.leaf_nodes.size(), 0.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, poke.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      detail::DistanceField::Probe probe(field);
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
                        const double d = probe.distance(node.center.cast<double>());
                        if (std::abs(d) < field.reliable_band()) poke[i] = node.radius + d;
                      }
                    });

  return pooled(to_union, poke);
}

Deviation measure_seam_deviation(std::span<const SphereTree* const> parts, const TriangleMesh& surface,
                                 const LevelSet& shape, const std::function<double(const Vec3&)>& border,
                                 double half_width_mm, std::size_t samples, uint64_t seed) {
  if (parts.empty()) throw Error("measure_seam_deviation: no parts");
  for (const SphereTree* tree : parts)
    if (tree == nullptr || tree->leaf_nodes.empty())
      throw Error("measure_seam_deviation: a part has no leaves");
  if (surface.triangles.empty()) throw Error("measure_seam_deviation: the surface mesh has no triangles");
  if (shape.empty()) throw Error("measure_seam_deviation: the level set is empty");
  if (samples == 0) throw Error("measure_seam_deviation: at least one surface sample is needed");

  // Surface side: samples on the band, each against the union of every part's leaves.
  const std::vector<Vec3> points = detail::sample_surface_band(surface, border, half_width_mm, samples, seed);
  std::vector<double> to_union(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<uint32_t> stack;
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        double best = std::numeric_limits<double>::infinity();
                        for (const SphereTree* tree : parts)
                          best = std::min(best, distance_to_union(*tree, points[i].cast<float>(), stack));
                        to_union[i] = best;
                      }
                    });

  // Leaf side: poke-out beyond the object's surface of every leaf that may reach the band.
  const detail::DistanceField field(shape, 0.0, 0.0);
  std::vector<double> poke;
  detail::DistanceField::Probe probe(field);
  for (const SphereTree* tree : parts) {
    for (const uint32_t index : tree->leaf_nodes) {
      // A leaf pokes out in a cap around its apex toward the nearest surface (c + r g, g the distance's
      // gradient): counted when that cap reaches the band.
      const SphereNode& node = tree->nodes[index];
      const Vec3 c = node.center.cast<double>();
      const double d = probe.distance(c);
      const double out = node.radius + d;
      if (!(out > 0.0) || std::abs(d) >= field.reliable_band()) continue;
      const Vec3 apex = c + double(node.radius) * probe.gradient(c);
      if (std::abs(border(apex)) <= half_width_mm + std::sqrt(2.0 * node.radius * out)) poke.push_back(out);
    }
  }
  if (points.empty() && poke.empty()) throw Error("measure_seam_deviation: the band holds no surface");
  return pooled(to_union, poke);
}

// Walks the tree from the root: every node reached once, children contiguous and after their parent,
// every child inside its parent, leaf tables pointing back at their nodes.
std::string check_tree(const SphereTree& tree, double slack_mm) {
  if (tree.nodes.empty()) {
    return tree.leaf_nodes.empty() ? std::string() : "leaf table is not empty but the tree has no nodes";
  }
  if (tree.leaf_depth.size() != tree.leaf_nodes.size()) {
    return fmt::format("leaf_depth has {} entries for {} leaves", tree.leaf_depth.size(),
                       tree.leaf_nodes.size());
  }
  std::vector<uint8_t> seen(tree.nodes.size(), 0);
  std::vector<std::pair<uint32_t, int>> stack{{0u, 0}};
  seen[0] = 1;
  std::size_t leaves = 0;
  int deepest = 0;
  while (!stack.empty()) {
    const auto [index, depth] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, depth);
    const SphereNode& node = tree.nodes[index];
    if (!node.center.allFinite() || !std::isfinite(node.radius) || node.radius < 0.0f) {
      return fmt::format("node {}: non-finite centre or bad radius {}", index, node.radius);
    }
    if (node.is_leaf()) {
      ++leaves;
      if (node.leaf >= tree.leaf_nodes.size() || tree.leaf_nodes[node.leaf] != index) {
        return fmt::format("node {}: leaf index {} does not map back to it", index, node.leaf);
      }
      continue;
    }
    if (node.first <= index || std::size_t(node.first) + node.count > tree.nodes.size()) {
      return fmt::format("node {}: children [{}, {}) are not a range after it", index, node.first,
                         std::size_t(node.first) + node.count);
    }
    for (uint32_t k = 0; k < node.count; ++k) {
      const uint32_t c = node.first + k;
      if (seen[c]) return fmt::format("node {} is the child of two parents", c);
      seen[c] = 1;
      const SphereNode& child = tree.nodes[c];
      const double reach = double((child.center - node.center).norm()) + child.radius;
      if (reach > double(node.radius) + slack_mm) {
        return fmt::format("node {}: child {} reaches {:.6f} mm beyond it", index, c, reach - node.radius);
      }
      stack.emplace_back(c, depth + 1);
    }
  }
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) return fmt::format("node {} is not reachable from the root", i);
  }
  if (leaves != tree.leaf_nodes.size()) {
    return fmt::format("{} leaves in the tree but {} in the leaf table", leaves, tree.leaf_nodes.size());
  }
  if (tree.levels != deepest + 1)
    return fmt::format("levels is {} but the deepest node is on level {}", tree.levels, deepest);
  return {};
}

}  // namespace cariesim
