// Stage 1, collision (docs/design.md §4 step 1): the sphere pairs the rows of one sub-step are made of,
// each measured once at the rows' configuration; and the re-check at a solution.
//
// collide() (collision module) finds the pairs and their sphere-against-sphere gaps; the geometry the
// rows use is measured here, by measure_pair, because a compliant leaf is measured against its
// tangent patch rather than its sphere (see below), which is the step's business, not collision's.
#include "render/pairs.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim::detail {

namespace {

// Force shading (shaded_normal): the mesh's normal is used in full where the sphere normal lies within
// 10 degrees of it (an inscribed sphere's tilt on smooth enamel: up to 7), leaned toward the sphere
// normal beyond, and the sphere normal alone beyond 15 (a tool meeting a cusp's ridge or a fissure's
// edge from the side, where the turned force jumped as the load moved between rows; docs/performance.md,
// "Eleventh round"); a mesh point further than kShadeReach from the contact point is not the surface
// there (the trees keep within 0.015 mm of it; on the oral slide a reach of 0.1 mm on a 0.2 mm grid
// cost 13 µs a step more, 0.05 mm 2 µs, 0.03 mm 1 µs).
constexpr double kShadeTopCos = 0.984807753012208;    // cos 10 degrees
constexpr double kShadeSideCos = 0.9659258262890683;  // cos 15 degrees
constexpr double kShadeReach = 0.03;                  // mm

}  // namespace

CollisionScratch::CollisionScratch(const Model& model)
    : placed(model.tool.tree), contacts(model.capacities.contacts) {
  order.resize(model.capacities.contacts);
  rank.resize(model.capacities.contacts);
  group_objects = model.objects.size();
  group_end.resize(model.tool.tree.leaf_count() * group_objects + 1);
  // Quotas per tool leaf: the full one within a region's radius of the tip, a smaller one beyond.
  const SphereTree& tool = model.tool.tree;
  std::vector<uint32_t> quota(tool.leaf_count(), kStepPairsPerToolLeaf);
  for (std::size_t i = 0; i < tool.leaf_count(); ++i)
    if (tool.nodes[tool.leaf_nodes[i]].center.cast<double>().norm() > kRegionRadius)
      quota[i] = kStepPairsPerFarToolLeaf;
  placed.set_leaf_quota(quota);
}

void set_leaf_margins(const Model& m, double trans, double rot, CollisionScratch& c) {
  // Each leaf's largest motion, trans + rot * reach, plus the contact margin; collide() sees the margin
  // of a tool node only when it reaches the node (PlacedTool::place with ReachMargins).
  c.margins = ReachMargins{trans, rot, m.settings.contact_margin};
}

PairGeometry measure_pair(const Model& m, const ModelConstants& k, const Pose& g, const PairRef& p) {
  const SphereTree& tree = m.objects[p.object].tree;
  const SphereNode& node = tree.nodes[p.object_node];
  const Vec3 c_t = g.transform(k.leaf_local[p.tool_leaf]);
  const Vec3 c_o = node.center.cast<double>();
  const double r_t = k.leaf_radius[p.tool_leaf];
  const double r_o = node.radius;
  PairGeometry out;
  out.lever = c_t - g.p;

  // Compliant tissue, with the tool over one of the leaf's tangent patches: depth below that patch's
  // plane, using the tangent that faces the tool. Every leaf of one flat patch then gives the same
  // depth and normal, however many overlap, and the depth stays right when the tool sinks deeper
  // than the leaf's centre.
  // A caries tree's walls (its interface with healthy tissue) are not a surface the tool can meet
  // (the healthy tree's walls there are): its leaves are measured against their exposed patches
  // only, and a leaf with nothing but wall patches is marked `wall` and ignored.
  const Vec3 d = c_t - c_o;
  if (!m.defaults.materials[node.material].rigid() && node.leaf < tree.leaf_tangents.size()) {
    const LeafTangents& t = tree.leaf_tangents[node.leaf];
    const bool lesion = m.objects[p.object].lesion >= 0;
    int best = -1;
    double best_h = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < t.count; ++j) {
      if (lesion && ((t.wall_mask >> j) & 1u)) continue;
      const double h = d.dot(t.normal[j].cast<double>());
      if (h > best_h) best_h = h, best = j;
    }
    out.wall = lesion && t.count > 0 && best < 0;
    if (best >= 0) {
      const Vec3 n_s = t.normal[best].cast<double>();
      const double lateral = (d - best_h * n_s).norm();
      if (lateral <= r_o) {
        out.normal = n_s;
        out.gap = best_h - r_o - r_t;
        out.lateral = lateral;
        out.internal = ((t.wall_mask >> best) & 1u) != 0;
        return out;
      }
    }
  }

  // Sphere against sphere.
  const double dist = d.norm();
  // Coincident centres: push along the tool's own axis, any finite direction will do.
  out.normal = dist > 1e-12 ? Vec3(d / dist) : Vec3(g.z_axis());
  out.gap = dist - r_t - r_o;
  return out;
}

Vec3 shaded_normal(const Model& m, const PairSet& pairs, int i) {
  const PairRef& ref = pairs.refs[i];
  const PairGeometry& geo = pairs.geometry[i];
  if (ref.object >= m.shading_surfaces.size() || m.shading_surfaces[ref.object].empty()) return geo.normal;
  // The contact point: the tool sphere's point toward the object sphere (r_t + r_o = distance - gap).
  const SphereNode& node = m.objects[ref.object].tree.nodes[ref.object_node];
  const Vec3 centre = pairs.at.p + geo.lever;
  const double r_t = (centre - node.center.cast<double>()).norm() - geo.gap - double(node.radius);
  MeshNearest::Hit hit;
  if (!m.shading_surfaces[ref.object].nearest(centre - r_t * geo.normal, kShadeReach, &hit))
    return geo.normal;
  const double c = hit.normal.dot(geo.normal);
  const double lean = std::clamp((c - kShadeSideCos) / (kShadeTopCos - kShadeSideCos), 0.0, 1.0);
  const Vec3 blend = lean * hit.normal + (1.0 - lean) * geo.normal;
  return blend.norm() > 1e-9 ? Vec3(blend.normalized()) : geo.normal;
}

namespace {

// Gap (mm) at g of a pair collide() found: the tool leaf's sphere against the object leaf's.
inline double sphere_gap(const Model& m, const ModelConstants& k, const Pose& g, const Mat3& rot,
                         const Contact& con) {
  const SphereNode& on = m.objects[con.object].tree.nodes[con.object_node];
  const Vec3 c_t = g.p + rot * k.leaf_local[con.tool_leaf];
  return (c_t - on.center.cast<double>()).norm() - k.leaf_radius[con.tool_leaf] - static_cast<double>(on.radius);
}

inline bool in_mask(ObjectMask mask, uint16_t object) { return ((mask >> object) & 1u) != 0; }

// Smallest gap at g (mm) of the tool with the objects in `objects`, from the pairs listed at the
// sub-step's start: each listed pair, and for a (tool leaf, object) whose quota was full, that leaf
// against the object's tree. +infinity when nothing is listed. `capped_hit` tells whether a capped
// combination is among the overlaps beyond `tol` (its pairs are not all listed).
double listed_worst(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g,
                    ObjectMask objects, double tol, bool* capped_hit = nullptr) {
  const Mat3 rot = g.q.toRotationMatrix();
  double worst = std::numeric_limits<double>::infinity();
  for (const Contact& con : c.contacts.view())
    if (in_mask(objects, con.object)) worst = std::min(worst, sphere_gap(m, k, g, rot, con));
  for (const ContactSet::Capped& cap : c.contacts.capped()) {
    if (!in_mask(objects, cap.object)) continue;
    const Vec3 centre = g.p + rot * k.leaf_local[cap.tool_leaf];
    const double gap = sphere_closest(centre, k.leaf_radius[cap.tool_leaf], m.objects[cap.object], 0.0, &c.budget);
    worst = std::min(worst, gap);
    if (capped_hit != nullptr && gap < -tol) *capped_hit = true;
  }
  return worst;
}

}  // namespace

bool group_pairs(CollisionScratch& c, std::size_t found, std::span<uint32_t> order) {
  const std::size_t objects = c.group_objects;
  const std::size_t groups = c.group_end.size() - 1;
  const auto group = [&](const Contact& con) { return std::size_t{con.tool_leaf} * objects + con.object; };
  uint32_t* end = c.group_end.data();
  std::fill(end, end + groups + 1, uint32_t{0});
  for (std::size_t i = 0; i < found; ++i) {
    const Contact& con = c.contacts[i];
    if (con.object >= objects || group(con) >= groups) return false;
    ++end[group(con) + 1];
  }
  for (std::size_t g = 0; g < groups; ++g) end[g + 1] += end[g];
  for (std::size_t i = 0; i < found; ++i) order[end[group(c.contacts[i])]++] = static_cast<uint32_t>(i);
  // The groups are in order, so an insertion by (group, gap) moves each pair only within its group.
  for (std::size_t i = 1; i < found; ++i) {
    const uint32_t moving = order[i];
    const Contact& x = c.contacts[moving];
    const std::size_t gx = group(x);
    std::size_t j = i;
    for (; j > 0; --j) {
      const Contact& y = c.contacts[order[j - 1]];
      if (group(y) != gx || !(x.gap < y.gap)) break;
      order[j] = order[j - 1];
    }
    order[j] = moving;
  }
  for (std::size_t i = 1; i < found; ++i) {
    const Contact& x = c.contacts[order[i - 1]];
    const Contact& y = c.contacts[order[i]];
    if (group(x) == group(y) && !(x.gap < y.gap)) return false;
  }
  return true;
}

bool listed_within(const Model& m, const ModelConstants& k, const CollisionScratch& c, const Pose& g,
                   double reach_mm) {
  const Mat3 rot = g.q.toRotationMatrix();
  for (const Contact& con : c.contacts.view())
    if (sphere_gap(m, k, g, rot, con) < reach_mm) return true;
  return false;
}

bool collect_pairs(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g0,
                   ObjectMask mask, PairSet& out) {
  // Every pair within its tool leaf's margin, a bounded number per (tool leaf, object).
  c.placed.place(g0, c.margins);
  c.contacts.clear();
  collide(c.placed, m.objects, mask, c.contacts, kStepPairsPerToolLeaf, &c.budget);
  c.complete = c.contacts.truncated() ? 0 : mask;
  const std::size_t found = c.contacts.size();
  out.count = 0;
  out.at = g0;
  const auto keep = [&](const Contact& con) {
    const PairRef ref{con.object_node, con.tool_leaf, con.object, false};
    out.refs[out.count] = ref;
    out.geometry[out.count] = measure_pair(m, k, g0, ref);
    ++out.count;
  };
  if (found <= kMaxPairs) {
    for (std::size_t i = 0; i < found; ++i) keep(c.contacts[i]);
    out.overflow = c.contacts.overflow();
    return !out.overflow;
  }

  // More pairs than the rows can use: share the list fairly. Each (tool leaf, object) keeps its
  // nearest pairs, the same number for all, as many as fit; a crowd of deep pairs (a handle in soft
  // tissue) then cannot push out the few that hold the tip on a lesion's surface.
  std::span<uint32_t> order(c.order.data(), found);
  if (!group_pairs(c, found, order)) {
    for (std::size_t i = 0; i < found; ++i) order[i] = static_cast<uint32_t>(i);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      const Contact& x = c.contacts[a];
      const Contact& y = c.contacts[b];
      if (x.tool_leaf != y.tool_leaf) return x.tool_leaf < y.tool_leaf;
      if (x.object != y.object) return x.object < y.object;
      return x.gap < y.gap;
    });
  }
  std::array<int, kStepPairsPerToolLeaf + 1> per_rank{};
  for (std::size_t i = 0; i < found; ++i) {
    const bool same = i > 0 && c.contacts[order[i]].tool_leaf == c.contacts[order[i - 1]].tool_leaf &&
                      c.contacts[order[i]].object == c.contacts[order[i - 1]].object;
    c.rank[i] =
        same ? static_cast<uint16_t>(std::min<int>(c.rank[i - 1] + 1, kStepPairsPerToolLeaf)) : uint16_t{0};
    ++per_rank[c.rank[i]];
  }
  int keep_below = 0, total = 0;
  while (keep_below < static_cast<int>(kStepPairsPerToolLeaf) && total + per_rank[keep_below] <= kMaxPairs)
    total += per_rank[keep_below++];
  for (std::size_t i = 0; i < found; ++i)
    if (c.rank[i] < keep_below) keep(c.contacts[order[i]]);
  out.overflow = true;
  return false;
}

namespace {

// The index of `ref` in `pairs`, appending it (measured at pairs.at) when it is not listed; -1 when
// it is not listed and the set is full.
int list_pair(const Model& m, const ModelConstants& k, const PairRef& ref, PairSet& pairs) {
  for (int j = 0; j < pairs.count; ++j) {
    const PairRef& p = pairs.refs[j];
    if (p.object_node == ref.object_node && p.tool_leaf == ref.tool_leaf && p.object == ref.object) return j;
  }
  if (pairs.count >= kMaxPairs) return -1;
  pairs.refs[pairs.count] = ref;
  pairs.geometry[pairs.count] = measure_pair(m, k, pairs.at, ref);
  return pairs.count++;
}

// Adds a pair found overlapping at a solution to `pairs` (forced) unless the set is full; a pair
// already listed without a row (its normal was close to a deeper pair's) is marked forced, so that
// it gets one.
void add_forced(const Model& m, const ModelConstants& k, const Contact& con, PairSet& pairs, Recheck& out) {
  const int j = list_pair(m, k, PairRef{con.object_node, con.tool_leaf, con.object, false}, pairs);
  if (j < 0 || pairs.refs[j].forced) return;
  pairs.refs[j].forced = true;
  ++out.added;
}

}  // namespace

Recheck recheck_rigid(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g1,
                      ObjectMask mask, PairSet& pairs) {
  // The deepest overlap with the rigid objects; within the tolerance nothing changes.
  Recheck out;
  const ObjectMask rigid = mask & k.rigid_mask;
  const double tol = m.settings.rigid_tolerance;
  if ((rigid & ~c.complete) == 0) {
    // Every pair that can overlap at g1 is listed, or its tool leaf is capped: measure them there
    // instead of traversing the trees.
    bool capped_hit = false;
    const double worst = listed_worst(m, k, c, g1, rigid, tol, &capped_hit);
    out.worst = std::min(worst, 0.0);
    if (!(worst < -tol)) return out;
    const Mat3 rot = g1.q.toRotationMatrix();
    for (const Contact& con : c.contacts.view())
      if (in_mask(rigid, con.object) && sphere_gap(m, k, g1, rot, con) < -tol) add_forced(m, k, con, pairs, out);
    if (capped_hit) {
      // A capped tool leaf overlaps: its overlapping leaves come from the object's tree.
      c.capped_overlaps.clear();
      for (const ContactSet::Capped& cap : c.contacts.capped()) {
        if (!in_mask(rigid, cap.object)) continue;
        const Vec3 centre = g1.p + rot * k.leaf_local[cap.tool_leaf];
        sphere_collide(centre, k.leaf_radius[cap.tool_leaf], cap.tool_leaf, cap.object, m.objects[cap.object],
                       -tol, c.capped_overlaps, &c.budget);
      }
      for (const Contact& con : c.capped_overlaps.view()) add_forced(m, k, con, pairs, out);
    }
    return out;
  }

  c.placed.place(g1, 0.0);
  const ClosestPair worst = closest(c.placed, m.objects, rigid, 0.0, &c.budget);
  if (!worst.complete) {
    // The work budget ran out before the check did: count it as an overlap that cannot be resolved,
    // so that the sub-step backtracks to where the tool was clear.
    out.worst = -std::numeric_limits<double>::infinity();
    return out;
  }
  out.worst = std::isfinite(worst.gap) ? worst.gap : 0.0;
  if (!(worst.gap < -tol)) return out;

  // Overlaps beyond the tolerance: bring every such pair into the set, measured at the rows'
  // configuration like the others.
  c.placed.place(g1, 0.0);
  c.contacts.clear();
  c.complete = 0;
  collide(c.placed, m.objects, rigid, c.contacts, kStepPairsPerToolLeaf, &c.budget);
  for (const Contact& con : c.contacts.view())
    if (con.gap < -tol) add_forced(m, k, con, pairs, out);
  return out;
}

double rigid_clearance(const Model& m, const ModelConstants& k, CollisionScratch& c, const Pose& g,
                       ObjectMask mask) {
  const ObjectMask rigid = mask & k.rigid_mask;
  if ((rigid & ~c.complete) == 0) return std::min(listed_worst(m, k, c, g, rigid, m.settings.rigid_tolerance), 0.0);
  c.placed.place(g, 0.0);
  const ClosestPair closest_pair = closest(c.placed, m.objects, mask & k.rigid_mask, 0.0, &c.budget);
  if (!closest_pair.complete) return -std::numeric_limits<double>::infinity();  // budget spent: not clear
  return std::isfinite(closest_pair.gap) ? std::min(closest_pair.gap, 0.0) : 0.0;
}

void mark_carried_pairs(const Model& m, const ModelConstants& k, const CarriedPairs& carried, ObjectMask mask,
                        PairSet& pairs) {
  for (int c = 0; c < carried.count; ++c) {
    const PairRef& ref = carried.refs[c];
    if (!in_mask(mask, ref.object)) continue;
    const int j = list_pair(m, k, ref, pairs);
    if (j >= 0) pairs.refs[j].carried = true;
  }
}

}  // namespace cariesim::detail
