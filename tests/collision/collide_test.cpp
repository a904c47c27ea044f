#include "cariesim/collision/collide.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <span>
#include <tuple>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using PairKey = std::tuple<uint16_t, uint16_t, uint32_t>;  // tool leaf, object, object node

// Random leaves around `middle` (mm) in a cube of half-size `extent`, radii in [r_min, r_max].
std::vector<LeafSphere> random_leaves(std::size_t n, std::mt19937& rng, const Vec3f& middle, float extent,
                                      float r_min, float r_max) {
  std::uniform_real_distribution<float> pos(-extent, extent);
  std::uniform_real_distribution<float> rad(r_min, r_max);
  std::vector<LeafSphere> leaves(n);
  for (std::size_t i = 0; i < n; ++i) {
    leaves[i].center = middle + Vec3f(pos(rng), pos(rng), pos(rng));
    leaves[i].radius = rad(rng);
    leaves[i].material = static_cast<uint16_t>(rng() % 5);
  }
  return leaves;
}

CollisionObject make_object(std::span<const LeafSphere> leaves, int branching, const char* name) {
  CollisionObject obj;
  obj.name = name;
  obj.tree = build_hierarchy(leaves, branching);
  return obj;
}

Pose random_pose(std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Pose pose;
  pose.p = Vec3(u(rng), u(rng), u(rng)) * spread;
  pose.q = Quat(u(rng), u(rng), u(rng), u(rng)).normalized();
  return pose;
}

// Every (tool leaf, object leaf) pair of the masked objects with gap below the tool leaf's margin,
// with its geometry.
struct BrutePair {
  Contact contact;
  ContactGeometry geometry;
};
std::map<PairKey, BrutePair> brute_force(const SphereTree& tool, const Pose& pose,
                                         std::span<const double> margins,
                                         std::span<const CollisionObject> objects, ObjectMask mask) {
  std::map<PairKey, BrutePair> pairs;
  for (std::size_t oi = 0; oi < objects.size(); ++oi) {
    if (((mask >> oi) & 1u) == 0) continue;
    const SphereTree& obj = objects[oi].tree;
    for (std::size_t tl = 0; tl < tool.leaf_count(); ++tl) {
      const SphereNode& tn = tool.nodes[tool.leaf_nodes[tl]];
      const Vec3 ct = pose.transform(tn.center.cast<double>());
      for (std::size_t ol = 0; ol < obj.leaf_count(); ++ol) {
        const uint32_t node = obj.leaf_nodes[ol];
        const SphereNode& on = obj.nodes[node];
        const Vec3 co = on.center.cast<double>();
        const double gap = (ct - co).norm() - tn.radius - on.radius;
        if (!(gap < margins[tl])) continue;
        BrutePair b;
        b.contact.gap = gap;
        b.contact.material = on.material;
        b.geometry.normal = (ct - co).normalized();
        b.geometry.point = co + b.geometry.normal * static_cast<double>(on.radius);
        b.geometry.lever = ct - pose.p;
        pairs[{static_cast<uint16_t>(tl), static_cast<uint16_t>(oi), node}] = b;
      }
    }
  }
  return pairs;
}

std::map<PairKey, Contact> as_map(const ContactSet& set) {
  std::map<PairKey, Contact> pairs;
  for (const Contact& c : set.view()) {
    const bool fresh = pairs.emplace(PairKey{c.tool_leaf, c.object, c.object_node}, c).second;
    EXPECT_TRUE(fresh) << "pair reported twice";
  }
  return pairs;
}

// Runs collide() for `placed` (already placed at `pose` with `margins`) and expects exactly the
// brute-force pair set, with the same data; contact_geometry gives each pair's normal, point and
// lever. Returns the number of pairs.
std::size_t expect_brute_force_pairs(PlacedTool& placed, const Pose& pose, std::span<const double> margins,
                                     std::span<const CollisionObject> objects, ObjectMask mask,
                                     ContactSet& set, int trial) {
  set.clear();
  collide(placed, objects, mask, set);
  EXPECT_FALSE(set.overflow()) << "trial " << trial;
  const std::map<PairKey, Contact> got = as_map(set);
  const std::map<PairKey, BrutePair> want = brute_force(placed.tree(), pose, margins, objects, mask);
  EXPECT_EQ(got.size(), want.size()) << "trial " << trial;
  for (const auto& [key, w] : want) {
    const auto it = got.find(key);
    if (it == got.end()) {
      ADD_FAILURE() << "missing pair in trial " << trial;
      continue;
    }
    const Contact& g = it->second;
    const ContactGeometry geo = contact_geometry(placed, objects, g);
    EXPECT_NEAR(g.gap, w.contact.gap, 1e-9);
    EXPECT_NEAR((geo.normal - w.geometry.normal).norm(), 0.0, 1e-9);
    EXPECT_NEAR((geo.point - w.geometry.point).norm(), 0.0, 1e-9);
    EXPECT_NEAR((geo.lever - w.geometry.lever).norm(), 0.0, 1e-9);
    EXPECT_EQ(g.material, w.contact.material);
  }
  return got.size();
}

// Random trees and poses: the traversal finds exactly the brute-force pair set, with the same data;
// contact_geometry gives each pair's normal, point and lever.
TEST(Collide, MatchesBruteForceOnRandomTrees) {
  std::mt19937 rng(42);
  const std::vector<LeafSphere> tool_leaves = random_leaves(120, rng, Vec3f(0, 0, 2), 2.5f, 0.03f, 0.4f);
  const SphereTree tool = build_hierarchy(tool_leaves, 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(3000, rng, Vec3f(0, 0, 0), 4.0f, 0.05f, 0.3f), 4, "a"));
  objects.push_back(make_object(random_leaves(1500, rng, Vec3f(2, 1, 0), 3.0f, 0.1f, 0.5f), 2, "b"));
  objects.push_back(make_object(random_leaves(700, rng, Vec3f(-2, 0, 1), 2.0f, 0.0f, 0.2f), 8, "c"));
  PlacedTool placed(tool);
  ContactSet set(1 << 16);
  std::uniform_real_distribution<double> per_leaf(0.0, 0.4);
  std::size_t total = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const Pose pose = random_pose(rng, 2.0);
    std::vector<double> margins(tool.leaf_count());
    const int kind = trial % 4;
    for (double& m : margins) m = kind == 0 ? 0.0 : kind == 1 ? 0.05 : kind == 2 ? 0.3 : per_leaf(rng);
    if (kind == 3) {
      placed.place(pose, margins);
    } else {
      placed.place(pose, margins[0]);
    }
    const ObjectMask mask = trial % 3 == 2 ? ObjectMask{0b101} : kAllObjects;
    total += expect_brute_force_pairs(placed, pose, margins, objects, mask, set, trial);
  }
  EXPECT_GT(total, 1000u) << "the random scenes should produce many pairs";
}

// A sphere hovering above a plane of spheres: the gap and normal follow from the geometry.
TEST(Collide, SphereAboveAPlaneOfSpheres) {
  constexpr float kR = 0.2f;     // plane spheres, mm
  constexpr double kTip = 0.05;  // tool sphere, mm
  std::vector<LeafSphere> plane;
  for (int i = -20; i <= 20; ++i) {
    for (int j = -20; j <= 20; ++j) {
      LeafSphere l{};
      l.center = Vec3f(0.5f * static_cast<float>(i), 0.5f * static_cast<float>(j), 0.0f);
      l.radius = kR;
      l.material = 3;
      plane.push_back(l);
    }
  }
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(plane, 4, "plane"));
  std::vector<LeafSphere> tip(1);
  tip[0].radius = static_cast<float>(kTip);
  tip[0].center = Vec3f::Zero();
  const SphereTree tool = build_hierarchy(tip, 4);
  PlacedTool placed(tool);
  ContactSet set(64);
  for (const double height : {0.3, 0.25, 0.2}) {
    Pose pose;
    pose.p = Vec3(1.5, -2.0, height);  // above the plane sphere at (1.5, -2, 0)
    placed.place(pose, 0.1);
    set.clear();
    collide(placed, objects, kAllObjects, set);
    ASSERT_EQ(set.size(), 1u) << "height " << height;
    const Contact& c = set[0];
    EXPECT_NEAR(c.gap, height - kTip - kR, 1e-6);
    const ContactGeometry geo = contact_geometry(placed, objects, c);
    EXPECT_NEAR((geo.normal - Vec3::UnitZ()).norm(), 0.0, 1e-9);
    EXPECT_NEAR((geo.point - Vec3(1.5, -2.0, kR)).norm(), 0.0, 1e-6);
    EXPECT_NEAR(geo.lever.norm(), 0.0, 1e-12);
    EXPECT_EQ(c.material, 3);
    EXPECT_EQ(c.tool_leaf, 0);
    const SphereNode& hit = objects[0].tree.nodes[c.object_node];
    EXPECT_NEAR((hit.center.cast<double>() - Vec3(1.5, -2.0, 0.0)).norm(), 0.0, 1e-6);
    const ClosestPair cp = closest(placed, objects, kAllObjects, 5.0);
    EXPECT_NEAR(cp.gap, height - kTip - kR, 1e-6);
    EXPECT_EQ(cp.object_node, c.object_node);
  }
  // Out of the margin: nothing.
  Pose far;
  far.p = Vec3(1.5, -2.0, 0.5);
  placed.place(far, 0.1);
  set.clear();
  collide(placed, objects, kAllObjects, set);
  EXPECT_EQ(set.size(), 0u);
}

TEST(ContactSet, KeepsTheSmallestGapsWhenFull) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ContactSet set(16);
  std::vector<double> gaps;
  for (int i = 0; i < 16; ++i) {
    Contact c;
    c.gap = u(rng);
    gaps.push_back(c.gap);
    set.push(c);
  }
  EXPECT_EQ(set.size(), 16u);
  EXPECT_FALSE(set.overflow()) << "exactly full is not an overflow";
  for (int i = 0; i < 500; ++i) {
    Contact c;
    c.gap = u(rng);
    c.object_node = static_cast<uint32_t>(i);
    gaps.push_back(c.gap);
    set.push(c);
  }
  EXPECT_TRUE(set.overflow());
  ASSERT_EQ(set.size(), 16u);
  std::sort(gaps.begin(), gaps.end());
  std::vector<double> kept;
  for (const Contact& c : set.view()) kept.push_back(c.gap);
  std::sort(kept.begin(), kept.end());
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(kept[i], gaps[i]);
  set.clear();
  EXPECT_EQ(set.size(), 0u);
  EXPECT_FALSE(set.overflow());
  ContactSet none(0);
  none.push(Contact{});
  EXPECT_EQ(none.size(), 0u);
  EXPECT_TRUE(none.overflow());
}

// A query with more pairs than capacity keeps the best of the brute-force set.
TEST(Collide, OverflowKeepsTheDeepestPairs) {
  std::mt19937 rng(9);
  const SphereTree tool = build_hierarchy(random_leaves(40, rng, Vec3f::Zero(), 1.0f, 0.2f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(2000, rng, Vec3f::Zero(), 2.0f, 0.1f, 0.3f), 4, "dense"));
  PlacedTool placed(tool);
  placed.place(Pose{}, 0.05);
  ContactSet big(1 << 16);
  collide(placed, objects, kAllObjects, big);
  ASSERT_GT(big.size(), 100u);
  ContactSet small(32);
  collide(placed, objects, kAllObjects, small);
  EXPECT_TRUE(small.overflow());
  ASSERT_EQ(small.size(), 32u);
  std::vector<double> all;
  for (const Contact& c : big.view()) all.push_back(c.gap);
  std::sort(all.begin(), all.end());
  std::vector<double> kept;
  for (const Contact& c : small.view()) kept.push_back(c.gap);
  std::sort(kept.begin(), kept.end());
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_DOUBLE_EQ(kept[i], all[i]);
}

TEST(Collide, RespectsTheObjectMask) {
  std::mt19937 rng(3);
  const SphereTree tool = build_hierarchy(random_leaves(30, rng, Vec3f::Zero(), 1.0f, 0.2f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  for (int i = 0; i < 3; ++i) {
    objects.push_back(make_object(random_leaves(300, rng, Vec3f::Zero(), 1.5f, 0.1f, 0.3f), 4, "o"));
  }
  PlacedTool placed(tool);
  placed.place(Pose{}, 0.05);
  ContactSet set(1 << 14);
  collide(placed, objects, kAllObjects, set);
  std::array<int, 3> per_object{};
  for (const Contact& c : set.view()) ++per_object[c.object];
  for (int count : per_object) EXPECT_GT(count, 0);
  set.clear();
  collide(placed, objects, ObjectMask{0b010}, set);
  ASSERT_GT(set.size(), 0u);
  for (const Contact& c : set.view()) EXPECT_EQ(c.object, 1);
  EXPECT_EQ(set.size(), static_cast<std::size_t>(per_object[1]));
  set.clear();
  collide(placed, objects, ObjectMask{0}, set);
  EXPECT_EQ(set.size(), 0u);
  EXPECT_TRUE(std::isinf(closest(placed, objects, ObjectMask{0}, 10.0).gap));
}

TEST(Collide, ClosestMatchesBruteForce) {
  std::mt19937 rng(5);
  const SphereTree tool = build_hierarchy(random_leaves(80, rng, Vec3f(0, 0, 3), 2.0f, 0.05f, 0.3f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(2500, rng, Vec3f::Zero(), 3.0f, 0.05f, 0.3f), 4, "a"));
  objects.push_back(make_object(random_leaves(900, rng, Vec3f(4, 0, 0), 1.0f, 0.05f, 0.3f), 3, "b"));
  PlacedTool placed(tool);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose pose = random_pose(rng, 5.0);
    placed.place(pose, 0.2);
    double want = std::numeric_limits<double>::infinity();
    for (std::size_t oi = 0; oi < objects.size(); ++oi) {
      const SphereTree& obj = objects[oi].tree;
      for (uint32_t tn : tool.leaf_nodes) {
        const Vec3 ct = pose.transform(tool.nodes[tn].center.cast<double>());
        for (uint32_t on : obj.leaf_nodes) {
          want = std::min(want, (ct - obj.nodes[on].center.cast<double>()).norm() - tool.nodes[tn].radius -
                                    obj.nodes[on].radius);
        }
      }
    }
    const ClosestPair got = closest(placed, objects, kAllObjects, 100.0);
    EXPECT_NEAR(got.gap, want, 1e-9) << "trial " << trial;
    // The pair it names gives that gap.
    const SphereNode& t = tool.nodes[tool.leaf_nodes[got.tool_leaf]];
    const SphereNode& o = objects[got.object].tree.nodes[got.object_node];
    ASSERT_TRUE(o.is_leaf());
    EXPECT_NEAR(
        (pose.transform(t.center.cast<double>()) - o.center.cast<double>()).norm() - t.radius - o.radius,
        want, 1e-9);
    // A search radius below the smallest gap finds nothing.
    EXPECT_TRUE(std::isinf(closest(placed, objects, kAllObjects, want - 1e-3).gap));
  }
}

// One sphere against a tree (the step's re-check of a capped tool leaf): the smallest gap and every
// leaf within a margin, as brute force finds them; interior fillers of a surface-only object skipped.
TEST(Collide, SphereQueriesMatchBruteForce) {
  std::mt19937 rng(11);
  std::vector<LeafSphere> leaves = random_leaves(2000, rng, Vec3f::Zero(), 3.0f, 0.05f, 0.3f);
  for (std::size_t i = 0; i < leaves.size(); i += 3) leaves[i].flags = kLeafInterior;
  CollisionObject object = make_object(leaves, 4, "a");
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 40; ++trial) {
    object.surface_only = trial % 2 == 0;
    const Vec3 c(u(rng), u(rng), u(rng));
    const double r = 0.1 + 0.05 * (trial % 5);
    const double margin = trial % 4 == 0 ? -0.05 : 0.1;
    double want = std::numeric_limits<double>::infinity();
    std::size_t within = 0;
    for (uint32_t on : object.tree.leaf_nodes) {
      const SphereNode& n = object.tree.nodes[on];
      if (object.surface_only && (n.flags & kLeafInterior)) continue;
      const double gap = (c - n.center.cast<double>()).norm() - r - n.radius;
      want = std::min(want, gap);
      within += gap < margin;
    }
    EXPECT_NEAR(sphere_closest(c, r, object, 100.0), want, 1e-9) << trial;
    EXPECT_TRUE(std::isinf(sphere_closest(c, r, object, want - 1e-3))) << trial;
    ContactSet set(4096);
    sphere_collide(c, r, 7, 2, object, margin, set);
    EXPECT_EQ(set.size(), within) << trial;
    for (const Contact& con : set.view()) {
      EXPECT_EQ(con.tool_leaf, 7);
      EXPECT_EQ(con.object, 2);
      EXPECT_LT(con.gap, margin);
    }
  }
}

// A per-leaf quota keeps each tool leaf's pairs to its quota, notes every (tool leaf, object) it cut,
// and leaves every other combination complete.
TEST(Collide, QuotaNotesTheCappedCombinations) {
  std::mt19937 rng(3);
  const SphereTree tool = build_hierarchy(random_leaves(60, rng, Vec3f(0, 0, 0.5f), 1.5f, 0.1f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(3000, rng, Vec3f::Zero(), 2.0f, 0.05f, 0.2f), 4, "a"));
  PlacedTool placed(tool);
  std::vector<uint32_t> quota(tool.leaf_count(), 3);
  quota[0] = 1000;
  placed.set_leaf_quota(quota);
  placed.place(Pose{}, 0.1);
  ContactSet set(1 << 16);
  collide(placed, objects, kAllObjects, set, 64);
  ASSERT_FALSE(set.truncated());
  std::map<uint16_t, std::size_t> per_leaf;
  for (const Contact& c : set.view()) ++per_leaf[c.tool_leaf];
  const std::vector<double> margins(tool.leaf_count(), 0.1);
  const std::map<PairKey, BrutePair> all = brute_force(tool, Pose{}, margins, objects, kAllObjects);
  std::map<uint16_t, std::size_t> want;
  for (const auto& [key, pair] : all) ++want[std::get<0>(key)];
  std::size_t capped = 0;
  for (const auto& [leaf, n] : want) {
    const std::size_t limit = leaf == 0 ? 64 : 3;
    EXPECT_EQ(per_leaf[leaf], std::min(n, limit)) << "leaf " << leaf;
    bool noted = false;
    for (const ContactSet::Capped& c : set.capped()) noted = noted || c.tool_leaf == leaf;
    EXPECT_EQ(noted, n > limit) << "leaf " << leaf;
    capped += n > limit;
  }
  EXPECT_GT(capped, 0u);
  EXPECT_EQ(set.capped().size(), capped);
}

// A tool whose leaves are all capped for an object is not descended further: with a small quota, a
// cluster of tool leaves sunk in a dense object costs a fraction of the node pairs that listing every
// overlap does (and reports the same pairs as the quota test above requires: the quota, noted).
TEST(Collide, ToolNodesWhoseLeavesAreAllCappedAreNotDescended) {
  std::mt19937 rng(21);
  const SphereTree tool = build_hierarchy(random_leaves(16, rng, Vec3f::Zero(), 0.3f, 0.04f, 0.06f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(6000, rng, Vec3f::Zero(), 0.6f, 0.05f, 0.15f), 4, "a"));
  PlacedTool placed(tool);
  placed.place(Pose{}, 0.05);
  ContactSet all(1 << 16), some(1 << 16);
  WorkBudget listing, capped;
  collide(placed, objects, kAllObjects, all, 1 << 20, &listing);
  collide(placed, objects, kAllObjects, some, 2, &capped);
  ASSERT_GT(all.size(), 16u * 10u) << "every tool leaf overlaps many object leaves";
  EXPECT_EQ(some.size(), 2u * tool.leaf_count());
  EXPECT_EQ(some.capped().size(), tool.leaf_count());
  EXPECT_LT(capped.used * 4, listing.used) << "capped " << capped.used << " listing " << listing.used;
}

// any_within() answers "is anything within the radius?" as closest() does, with a pair that is, and
// stops at the first one it meets.
TEST(Collide, AnyWithinAgreesWithClosestAndStopsEarly) {
  std::mt19937 rng(9);
  const SphereTree tool = build_hierarchy(random_leaves(80, rng, Vec3f(0, 0, 3), 2.0f, 0.05f, 0.3f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(2500, rng, Vec3f::Zero(), 3.0f, 0.05f, 0.3f), 4, "a"));
  PlacedTool placed(tool);
  int near = 0, cheaper = 0;
  for (int trial = 0; trial < 40; ++trial) {
    placed.place(random_pose(rng, 6.0), 0.0);
    const double search = 0.2;
    WorkBudget full, first;
    const ClosestPair best = closest(placed, objects, kAllObjects, search, &full);
    const ClosestPair any = any_within(placed, objects, kAllObjects, search, &first);
    ASSERT_TRUE(best.complete && any.complete);
    EXPECT_EQ(std::isfinite(any.gap), std::isfinite(best.gap)) << trial;
    EXPECT_LE(first.used, full.used) << trial;
    if (!std::isfinite(best.gap)) continue;
    ++near;
    cheaper += first.used < full.used;
    // The pair it names is within the radius, with the gap it reports.
    EXPECT_LT(any.gap, search);
    EXPECT_GE(any.gap, best.gap);
    const SphereNode& t = tool.nodes[tool.leaf_nodes[any.tool_leaf]];
    const SphereNode& o = objects[any.object].tree.nodes[any.object_node];
    ASSERT_TRUE(o.is_leaf());
    EXPECT_NEAR((placed.pose().transform(t.center.cast<double>()) - o.center.cast<double>()).norm() -
                    t.radius - o.radius,
                any.gap, 1e-9);
  }
  EXPECT_GT(near, 10);
  EXPECT_GT(cheaper, near / 2) << "stopping at the first pair saves work when the tool is near";
}

// A work budget stops the queries where they are and says so.
TEST(Collide, WorkBudgetStopsTheQueries) {
  std::mt19937 rng(8);
  const SphereTree tool = build_hierarchy(random_leaves(100, rng, Vec3f(0, 0, 0), 2.0f, 0.05f, 0.3f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(3000, rng, Vec3f::Zero(), 3.0f, 0.05f, 0.3f), 4, "a"));
  PlacedTool placed(tool);
  placed.place(Pose{}, 0.05);
  ContactSet full(1 << 16), cut(1 << 16);
  WorkBudget unbounded;
  collide(placed, objects, kAllObjects, full, 1 << 20, &unbounded);
  ASSERT_FALSE(full.overflow());
  ASSERT_GT(unbounded.used, 200);
  WorkBudget small{100, 0};
  collide(placed, objects, kAllObjects, cut, 1 << 20, &small);
  EXPECT_TRUE(cut.overflow());
  EXPECT_TRUE(small.spent());
  EXPECT_EQ(small.used, 100);
  EXPECT_LT(cut.size(), full.size());

  WorkBudget none{0, 0};
  EXPECT_FALSE(closest(placed, objects, kAllObjects, 0.0, &none).complete);
  WorkBudget plenty;
  EXPECT_TRUE(closest(placed, objects, kAllObjects, 0.0, &plenty).complete);
  WorkBudget spent{0, 0};
  EXPECT_EQ(sphere_closest(Vec3::Zero(), 0.2, objects[0], 1.0, &spent),
            -std::numeric_limits<double>::infinity());
}

// Coincident centres and zero radii give finite contacts; the normal falls back to the tool axis.
TEST(Collide, CoincidentCentresAndZeroRadiiStayFinite) {
  std::vector<LeafSphere> obj_leaves(2);
  obj_leaves[0].center = Vec3f(1.0f, 2.0f, 3.0f);
  obj_leaves[0].radius = 0.0f;
  obj_leaves[1].center = Vec3f(1.0f, 2.0f, 3.0f);
  obj_leaves[1].radius = 0.3f;
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(obj_leaves, 2, "pointy"));
  std::vector<LeafSphere> tool_leaves(2);
  tool_leaves[0].center = Vec3f::Zero();
  tool_leaves[0].radius = 0.0f;
  tool_leaves[1].center = Vec3f(0.0f, 0.0f, 0.0f);
  tool_leaves[1].radius = 0.1f;
  const SphereTree tool = build_hierarchy(tool_leaves, 2);
  PlacedTool placed(tool);
  Pose pose;
  pose.p = Vec3(1.0, 2.0, 3.0);
  pose.q = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 1, 0).normalized()));
  placed.place(pose, 0.0);
  ContactSet set(16);
  collide(placed, objects, kAllObjects, set);
  ASSERT_EQ(set.size(), 3u) << "point-point at distance 0 has gap 0, not below a zero margin";
  for (const Contact& c : set.view()) {
    const ContactGeometry geo = contact_geometry(placed, objects, c);
    EXPECT_TRUE(geo.normal.allFinite());
    EXPECT_NEAR(geo.normal.norm(), 1.0, 1e-12);
    EXPECT_NEAR((geo.normal - pose.z_axis()).norm(), 0.0, 1e-12);
    EXPECT_TRUE(geo.point.allFinite());
    EXPECT_TRUE(std::isfinite(c.gap));
    EXPECT_LE(c.gap, 0.0);
  }
  const ClosestPair cp = closest(placed, objects, kAllObjects, 1.0);
  EXPECT_NEAR(cp.gap, -0.4, 1e-6);
}

TEST(Collide, NonFinitePoseGivesNoContacts) {
  std::mt19937 rng(1);
  const SphereTree tool = build_hierarchy(random_leaves(30, rng, Vec3f::Zero(), 1.0f, 0.2f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(300, rng, Vec3f::Zero(), 1.5f, 0.1f, 0.3f), 4, "o"));
  PlacedTool placed(tool);
  Pose pose;
  pose.p.x() = std::numeric_limits<double>::quiet_NaN();
  placed.place(pose, std::numeric_limits<double>::infinity());
  ContactSet set(64);
  collide(placed, objects, kAllObjects, set);
  EXPECT_EQ(set.size(), 0u);
  EXPECT_TRUE(std::isinf(closest(placed, objects, kAllObjects, 10.0).gap));
}

TEST(PlacedTool, InflatesLeavesAndTheirAncestors) {
  std::mt19937 rng(2);
  const SphereTree tool = build_hierarchy(random_leaves(50, rng, Vec3f::Zero(), 2.0f, 0.05f, 0.3f), 4);
  PlacedTool placed(tool);
  std::vector<double> margins(tool.leaf_count(), 0.0);
  margins[17] = 0.5;
  placed.place(Pose{}, margins);
  // Every node's inflated sphere holds every inflated leaf below it.
  for (std::size_t i = 0; i < tool.nodes.size(); ++i) {
    std::vector<uint32_t> stack{static_cast<uint32_t>(i)};
    while (!stack.empty()) {
      const uint32_t k = stack.back();
      stack.pop_back();
      const SphereNode& n = tool.nodes[k];
      if (n.is_leaf()) {
        EXPECT_LE((placed.centers()[k] - placed.centers()[i]).norm() + n.radius + margins[n.leaf],
                  placed.radii()[i] + 1e-9)
            << "node " << i << " leaf " << n.leaf << " diff "
            << ((placed.centers()[k] - placed.centers()[i]).norm() + n.radius + margins[n.leaf] -
                placed.radii()[i]);
      } else {
        for (uint32_t c = n.first; c < n.first + n.count; ++c) stack.push_back(c);
      }
    }
  }
  EXPECT_NEAR(placed.radii()[tool.leaf_nodes[17]], tool.nodes[tool.leaf_nodes[17]].radius + 0.5, 1e-7);
  EXPECT_NEAR(placed.radii()[tool.leaf_nodes[3]], tool.nodes[tool.leaf_nodes[3]].radius, 1e-7);
  EXPECT_GT(placed.radii()[0], tool.nodes[0].radius + 0.4);
}

// Issue #11: margins by reach give the pairs, leaf margins and radii of the table of the same margins
// (the step's margins: the sub-step's translation bound plus its rotation bound times each leaf's
// reach), although each node's radius is made only when a query reaches it.
TEST(PlacedTool, MarginsByReachMatchTheirTable) {
  std::mt19937 rng(11);
  const SphereTree tool = build_hierarchy(random_leaves(120, rng, Vec3f(0, 0, 2), 2.5f, 0.03f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(2000, rng, Vec3f(0, 0, 0), 4.0f, 0.05f, 0.3f), 4, "a"));
  objects.push_back(make_object(random_leaves(800, rng, Vec3f(-2, 0, 1), 2.0f, 0.0f, 0.2f), 8, "b"));
  const std::array<ReachMargins, 6> rules{{
      {0.05, 0.02, 0.01},
      {0.0, 0.1, 0.0},
      {0.2, 0.0, 0.005},
      {-0.3, 0.15, 0.0},                                      // negative near the origin: zero there
      {0.05, -1.0, 0.0},                                      // a negative rate counts as zero
      {0.1, std::numeric_limits<double>::quiet_NaN(), 0.0}}};  // non-finite: every margin zero
  PlacedTool by_reach(tool);
  PlacedTool by_table(tool);
  ContactSet set(1 << 16);
  std::size_t total = 0;
  for (std::size_t trial = 0; trial < 2 * rules.size(); ++trial) {
    const ReachMargins& rule = rules[trial % rules.size()];
    const Pose pose = random_pose(rng, 1.5);
    std::vector<double> margins(tool.leaf_count());
    for (std::size_t i = 0; i < tool.leaf_count(); ++i)
      margins[i] = rule.at(tool.nodes[tool.leaf_nodes[i]].center.cast<double>().norm());
    by_reach.place(pose, rule);
    total += expect_brute_force_pairs(by_reach, pose, margins, objects, kAllObjects, set, static_cast<int>(trial));
    by_table.place(pose, margins);
    for (std::size_t i = 0; i < tool.leaf_count(); ++i) {
      EXPECT_EQ(by_reach.leaf_margins()[i], margins[i]) << "trial " << trial << " leaf " << i;
      EXPECT_GE(margins[i], 0.0);
    }
    for (std::size_t i = 0; i < tool.nodes.size(); ++i)
      EXPECT_NEAR(by_reach.radii()[i], by_table.radii()[i], 1e-12) << "trial " << trial << " node " << i;
  }
  EXPECT_GT(total, 200u) << "the random scenes should produce pairs";
  // A table placement without a table keeps the margins by reach of the call before.
  by_reach.place(Pose{}, rules[0]);
  by_reach.place(Pose{}, std::span<const double>{});
  for (std::size_t i = 0; i < tool.leaf_count(); ++i)
    EXPECT_EQ(by_reach.leaf_margins()[i], rules[0].at(tool.nodes[tool.leaf_nodes[i]].center.cast<double>().norm()));
}

// Issue #11: a placement moves a node only when a query reaches it, so one placed tool reused along a
// path must answer every query as a tool placed afresh at each pose would: nothing of an earlier pose
// is left in what the queries read, and the accessors give the whole tool at the current pose.
TEST(PlacedTool, AReusedPlacementAnswersAsAFreshOne) {
  std::mt19937 rng(12);
  const SphereTree tool = build_hierarchy(random_leaves(90, rng, Vec3f(0, 0, 2), 2.0f, 0.05f, 0.3f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(1500, rng, Vec3f(0, 0, 0), 3.0f, 0.05f, 0.3f), 4, "a"));
  objects.push_back(make_object(random_leaves(600, rng, Vec3f(1, 1, 1), 2.0f, 0.05f, 0.2f), 2, "b"));
  PlacedTool reused(tool);
  ContactSet got(1 << 16);
  ContactSet want(1 << 16);
  std::size_t pairs = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Pose pose = random_pose(rng, 1.0);
    const ReachMargins rule{0.02 * (trial % 3), 0.01 * (trial % 4), 0.01};
    if (trial % 2 == 0) {
      reused.place(pose, rule);
    } else {
      reused.place(pose, 0.05);
    }
    PlacedTool fresh(tool);
    if (trial % 2 == 0) {
      fresh.place(pose, rule);
    } else {
      fresh.place(pose, 0.05);
    }
    got.clear();
    want.clear();
    collide(reused, objects, kAllObjects, got);
    collide(fresh, objects, kAllObjects, want);
    ASSERT_EQ(got.size(), want.size()) << "trial " << trial;
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].gap, want[i].gap) << "trial " << trial;
      EXPECT_EQ(got[i].object_node, want[i].object_node) << "trial " << trial;
      EXPECT_EQ(got[i].tool_leaf, want[i].tool_leaf) << "trial " << trial;
    }
    pairs += got.size();
    const ClosestPair a = closest(reused, objects, kAllObjects, 3.0);
    const ClosestPair b = closest(fresh, objects, kAllObjects, 3.0);
    EXPECT_EQ(a.gap, b.gap) << "trial " << trial;
    EXPECT_EQ(a.object_node, b.object_node) << "trial " << trial;
    // Every node at this pose, whether a query reached it or not.
    const Mat3 rot = pose.q.toRotationMatrix();
    for (std::size_t i = 0; i < tool.nodes.size(); ++i) {
      const Vec3 world = pose.p + rot * tool.nodes[i].center.cast<double>();
      EXPECT_EQ(reused.centers()[i], world) << "trial " << trial << " node " << i;
      EXPECT_EQ(reused.radii()[i], fresh.radii()[i]) << "trial " << trial << " node " << i;
    }
  }
  EXPECT_GT(pairs, 500u) << "the random scenes should produce pairs";
}

// Leaves of radius `r` (mm) along a wire: a straight shank from z = 0 to z = `length` (mm), then, with
// `hook`, a quarter circle of radius 3 mm bending toward +x (an explorer's shape).
std::vector<LeafSphere> wire_leaves(double length, float r, bool hook) {
  std::vector<LeafSphere> leaves;
  for (double z = 0.0; z <= length + 1e-9; z += 0.1)
    leaves.push_back({Vec3f(0, 0, static_cast<float>(z)), r, 0});
  for (int k = 1; hook && k <= 40; ++k) {
    const double a = 0.5 * M_PI * k / 40.0;
    leaves.push_back({Vec3f(static_cast<float>(3.0 - 3.0 * std::cos(a)), 0.0f,
                            static_cast<float>(length + 3.0 * std::sin(a))),
                      r, 0});
  }
  return leaves;
}

// Issue #11: inner nodes of a tool whose leaves lie along a line get a capsule that holds every leaf
// below (inflated like the node's sphere); a cluster that the wire's spheres reach but its capsules do
// not costs no node pair at all (without capsules the descent visits the shank's nodes), and on a
// hooked wire the pairs found are still exactly the brute-force ones.
TEST(PlacedTool, CapsulesHoldTheLeavesAndPruneWhatTheSpheresCannot) {
  const SphereTree straight = build_hierarchy(wire_leaves(20.0, 0.2f, false), 4);
  PlacedTool placed(straight);
  std::size_t capsules = 0;
  for (uint8_t has : placed.has_capsule()) capsules += has;
  EXPECT_GT(capsules, 10u) << "a straight wire's inner nodes all lie along a line";
  EXPECT_EQ(placed.has_capsule()[0], 1) << "the root of a straight wire";

  // A small cluster of leaves 3 mm beside the middle of the shank: inside the root's sphere (radius
  // about 10 mm), 2.4 mm from the shank's leaves.
  std::vector<LeafSphere> plate;
  for (float y = -0.2f; y <= 0.2f; y += 0.1f)
    for (float z = 9.8f; z <= 10.2f; z += 0.1f) plate.push_back({Vec3f(3.0f, y, z), 0.1f, 1});
  std::vector<CollisionObject> objects{make_object(plate, 4, "cluster")};
  const std::array<double, 2> margins{0.0, 0.5};  // mm
  for (double margin : margins) {
    placed.place(Pose{}, margin);
    ContactSet set(4096);
    WorkBudget budget;
    collide(placed, objects, kAllObjects, set, std::numeric_limits<uint32_t>::max(), &budget);
    EXPECT_EQ(set.size(), 0u);
    EXPECT_EQ(budget.used, 0) << "margin " << margin << ": the root's capsule misses the plate";
  }

  // Hooked wire, random poses and margins: every capsule holds its inflated leaves, and the pairs
  // are the brute-force ones.
  const SphereTree hooked = build_hierarchy(wire_leaves(12.0, 0.15f, true), 4);
  PlacedTool hook(hooked);
  std::mt19937 rng(11);
  std::vector<CollisionObject> teeth;
  teeth.push_back(make_object(random_leaves(4000, rng, Vec3f(0, 0, 6), 6.0f, 0.05f, 0.3f), 4, "a"));
  teeth.push_back(make_object(random_leaves(2000, rng, Vec3f(3, 0, 12), 3.0f, 0.02f, 0.2f), 8, "b"));
  std::uniform_real_distribution<double> per_leaf(0.0, 0.3);
  ContactSet set(1 << 16);
  std::size_t total = 0;
  for (int trial = 0; trial < 10; ++trial) {
    const Pose pose = random_pose(rng, 3.0);
    std::vector<double> leaf_margins(hooked.leaf_count());
    for (double& m : leaf_margins) m = trial % 2 == 0 ? 0.1 : per_leaf(rng);
    hook.place(pose, leaf_margins);
    for (std::size_t i = 0; i < hooked.nodes.size(); ++i) {
      if (hook.has_capsule()[i] == 0) continue;
      std::vector<uint32_t> stack{static_cast<uint32_t>(i)};
      while (!stack.empty()) {
        const uint32_t k = stack.back();
        stack.pop_back();
        const SphereNode& n = hooked.nodes[k];
        if (!n.is_leaf()) {
          for (uint32_t c = n.first; c < n.first + n.count; ++c) stack.push_back(c);
          continue;
        }
        const Vec3 w = hook.centers()[k] - hook.capsule_a()[i];
        const Vec3& d = hook.capsule_d()[i];
        const double s = std::clamp(w.dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
        EXPECT_LE((w - s * d).norm() + n.radius + leaf_margins[n.leaf], hook.capsule_radii()[i] + 1e-9)
            << "node " << i << " leaf " << n.leaf;
      }
    }
    total += expect_brute_force_pairs(hook, pose, leaf_margins, teeth, kAllObjects, set, trial);
  }
  EXPECT_GT(total, 200u) << "the hooked wire should touch the random teeth";
}

TEST(PlacedTool, RejectsATreeWithChildrenBeforeTheirParent) {
  SphereTree bad;
  bad.nodes.resize(3);
  bad.nodes[1].first = 0;  // node 1 claims node 0 and 1 as children
  bad.nodes[1].count = 2;
  bad.nodes[0].first = 1;
  bad.nodes[0].count = 2;
  bad.leaf_nodes = {2};
  EXPECT_THROW(PlacedTool{bad}, Error);
}

TEST(Collide, PlaceAndCollideDoNotAllocate) {
  std::mt19937 rng(4);
  const SphereTree tool = build_hierarchy(random_leaves(200, rng, Vec3f(0, 0, 3), 3.0f, 0.05f, 0.4f), 4);
  std::vector<CollisionObject> objects;
  objects.push_back(make_object(random_leaves(20000, rng, Vec3f::Zero(), 5.0f, 0.1f, 0.3f), 4, "a"));
  objects.push_back(make_object(random_leaves(2000, rng, Vec3f(3, 0, 0), 2.0f, 0.1f, 0.3f), 4, "b"));
  PlacedTool placed(tool);
  ContactSet set(256);
  std::vector<double> margins(tool.leaf_count(), 0.08);
  std::vector<Pose> poses;
  for (int i = 0; i < 50; ++i) poses.push_back(random_pose(rng, 3.0));
  std::size_t contacts = 0;
  const std::size_t before = test::allocation_count();
  for (const Pose& pose : poses) {
    placed.place(pose, margins);
    set.clear();
    collide(placed, objects, kAllObjects, set);
    contacts += set.size();
    placed.place(pose, 0.1);
    (void)closest(placed, objects, kAllObjects, 1.0);
  }
  const std::size_t after = test::allocation_count();
  EXPECT_EQ(after - before, 0u);
  EXPECT_GT(contacts, 0u);
}

}  // namespace
}  // namespace cariesim
