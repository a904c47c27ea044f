// The step's first stages, tested directly (src/render/pairs.hpp, regions.hpp, contact_rows.hpp,
// solve.hpp): collision (pairs measured once), regions, contact rows and the solve, with closed-form
// checks on a sphere over a plane.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "render/contact_rows.hpp"
#include "render/pairs.hpp"
#include "render/regions.hpp"
#include "render/render_support.hpp"
#include "render/solve.hpp"
#include "render/state_impl.hpp"

namespace cariesim {
namespace {

using namespace detail;
using test::probe_at;

constexpr double kTip = 0.05;   // mm, the straight probe's tip radius
constexpr double kSlabR = 2.0;  // mm, the slab's sphere radius

// One slab (top z = 0) of the given material, rigid or soft.
Model slab_model(const Material& material, ObjectKind kind) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -3.0;
  spec.x1 = spec.y1 = 3.0;
  return test::model({test::object("slab", test::slab(spec, [](const Vec3&) { return 0; }), kind)},
                     {material});
}

// The node of object `object` whose leaf sphere is centred at `center`.
uint32_t node_at(const Model& m, int object, const Vec3& center) {
  const SphereTree& tree = m.objects[object].tree;
  for (uint32_t node : tree.leaf_nodes)
    if ((tree.nodes[node].center.cast<double>() - center).norm() < 1e-6) return node;
  ADD_FAILURE() << "no leaf at " << center.transpose();
  return 0;
}

// A rigid leaf is measured sphere against sphere: the gap, the normal from the object sphere's
// centre, the lever from the tool-frame origin.
TEST(MeasurePair, RigidLeafIsSphereAgainstSphere) {
  const Model m = slab_model(test::enamel(), ObjectKind::Rigid);
  State state(m, probe_at(Vec3(0, 0, 5)));
  const ModelConstants& k = state_impl(state).constants;
  const PairRef under{node_at(m, 0, Vec3(0, 0, -kSlabR)), 0, 0, false};
  // The tip 0.1 mm sideways and 0.03 mm above the plane.
  const Pose g = probe_at(Vec3(0.1, 0.0, kTip + 0.03));
  const PairGeometry geo = measure_pair(m, k, g, under);
  const Vec3 d = g.p - Vec3(0, 0, -kSlabR);
  const double r_o = m.objects[0].tree.nodes[under.object_node].radius;  // float storage
  EXPECT_NEAR(geo.gap, d.norm() - k.leaf_radius[0] - r_o, 1e-12);
  EXPECT_NEAR(geo.gap, d.norm() - kTip - kSlabR, 1e-6);
  EXPECT_NEAR((geo.normal - d.normalized()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(geo.lever.norm(), 0.0, 1e-12);
  EXPECT_TRUE(std::isinf(geo.lateral));
  EXPECT_FALSE(geo.wall);
  // A leaf up the tool: its lever is its centre, turned with the tool.
  const Pose tilted{Vec3(0, 0, 3), Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY()))};
  const int leaf = static_cast<int>(k.tool_leaves) - 1;
  const PairGeometry up =
      measure_pair(m, k, tilted, PairRef{under.object_node, static_cast<uint16_t>(leaf), 0, false});
  EXPECT_NEAR((up.lever - tilted.q * k.leaf_local[leaf]).norm(), 0.0, 1e-12);
}

// A compliant leaf under the tool is measured against its tangent plane: depth below the plane,
// the plane's normal, and how far sideways the tool lies from the tangent point.
TEST(MeasurePair, CompliantLeafIsMeasuredAgainstItsTangentPlane) {
  const Model m = slab_model(test::soft(0.5), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  const ModelConstants& k = state_impl(state).constants;
  const PairRef under{node_at(m, 0, Vec3(0, 0, -kSlabR)), 0, 0, false};
  const PairGeometry geo = measure_pair(m, k, probe_at(Vec3(0.1, 0.0, kTip - 0.02)), under);
  EXPECT_NEAR(geo.gap, -0.02, 1e-6);  // the plane's depth, not the sphere's (-0.0175)
  EXPECT_NEAR((geo.normal - Vec3::UnitZ()).norm(), 0.0, 1e-7);
  EXPECT_NEAR(geo.lateral, 0.1, 1e-6);
  // Beside the leaf (farther sideways than its radius): sphere against sphere again.
  const Pose beside = probe_at(Vec3(2.5, 0.0, kTip - 0.02));
  const PairGeometry far = measure_pair(m, k, beside, under);
  EXPECT_TRUE(std::isinf(far.lateral));
  EXPECT_NEAR(far.gap, (beside.p - Vec3(0, 0, -kSlabR)).norm() - kTip - kSlabR, 1e-9);
}

// A caries tree's leaf with nothing but wall patches (its interface with healthy tissue) is marked
// and belongs to no region; the same leaf in a healthy tree is an ordinary surface.
TEST(MeasurePair, CariesWallLeafIsMarkedAndLeftOut) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -1.0;
  spec.x1 = spec.y1 = 1.0;
  std::vector<LeafSphere> walls = test::slab(spec, [](const Vec3&) { return 0; });
  for (LeafSphere& l : walls) l.tangents.wall_mask = 1;
  Material caries = test::soft(0.5, 0.0, 0.0, Tissue::Caries);
  caries.lesion = 0;
  const Model m = test::model(
      {test::object("caries", walls, ObjectKind::Soft, 0), test::object("healthy", walls, ObjectKind::Soft)},
      {caries});
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  const Pose g = probe_at(Vec3(0, 0, kTip - 0.1));
  const PairRef in_lesion{node_at(m, 0, Vec3(0, 0, -kSlabR)), 0, 0, false};
  const PairRef in_healthy{node_at(m, 1, Vec3(0, 0, -kSlabR)), 0, 1, false};
  EXPECT_TRUE(measure_pair(m, s.constants, g, in_lesion).wall);
  EXPECT_FALSE(measure_pair(m, s.constants, g, in_healthy).wall);
  test::collect(m, s, g, 0.01);
  build_regions(m, s.constants, s.pairs, s.regions);
  ASSERT_GT(s.pairs.count, 0);
  ASSERT_EQ(s.regions.count, 1);
  EXPECT_EQ(s.regions.regions[0].object, 1);
  for (int i = 0; i < s.pairs.count; ++i)
    EXPECT_EQ(s.regions.pair_region[i] < 0, s.pairs.refs[i].object == 0) << i;
}

// The collision stage measures every pair once, at the rows' configuration: the stored geometry is
// measure_pair's at `at`, bit for bit, and the nearest pair is the closed-form gap.
TEST(CollectPairs, MeasuresEachPairOnceAtTheRowsConfiguration) {
  const Model m = slab_model(test::enamel(), ObjectKind::Rigid);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  const Pose g = probe_at(Vec3(0.0, 0.0, kTip + 0.01));
  test::collect(m, s, g, 0.05);
  ASSERT_GT(s.pairs.count, 0);
  EXPECT_FALSE(s.pairs.overflow);
  EXPECT_EQ(s.pairs.at.p, g.p);
  double nearest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < s.pairs.count; ++i) {
    const PairGeometry again = measure_pair(m, s.constants, g, s.pairs.refs[i]);
    EXPECT_EQ(s.pairs.geometry[i].gap, again.gap) << i;
    EXPECT_EQ(s.pairs.geometry[i].normal, again.normal) << i;
    EXPECT_FALSE(s.pairs.refs[i].forced);
    // Within the margin: the sub-step's reach plus the contact margin.
    EXPECT_LT(s.pairs.geometry[i].gap, 0.05 + m.settings.contact_margin + 1e-9);
    nearest = std::min(nearest, s.pairs.geometry[i].gap);
  }
  EXPECT_NEAR(nearest, 0.01, 1e-6);
}

// More pairs than the contact capacity: the stage reports overflow and keeps what fits.
TEST(CollectPairs, ReportsOverflow) {
  Model m = slab_model(test::enamel(), ObjectKind::Rigid);
  m.capacities.contacts = 4;
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  set_leaf_margins(m, 0.5, 0.0, s.collision);
  EXPECT_FALSE(
      collect_pairs(m, s.constants, s.collision, probe_at(Vec3(0, 0, kTip + 0.01)), kAllObjects, s.pairs));
  EXPECT_TRUE(s.pairs.overflow);
  EXPECT_EQ(s.pairs.count, 4);
}

// Regions: pairs sorted from the deepest; one region per object and nearby tool point, founded by
// the deepest pair, regions of one object at least kRegionRadius apart; the tip's region is marked.
// Here the tip sinks into a soft floor and the shank into a soft wall.
TEST(BuildRegions, OnePerObjectAndToolPointFoundedByTheDeepest) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -2.0;
  spec.x1 = spec.y1 = 2.0;
  const auto leaves = test::slab(spec, [](const Vec3&) { return 0; });
  auto wall = leaves;  // a second slab turned into the wall x = 2.5, facing -x, over z in [2, 6]
  for (LeafSphere& l : wall) {
    l.center = Vec3f(2.5f + static_cast<float>(kSlabR), l.center.y(), l.center.x() + 4.0f);
    l.tangents.normal[0] = -Vec3f::UnitX();
  }
  const Model m = test::model(
      {test::object("floor", leaves, ObjectKind::Soft), test::object("wall", wall, ObjectKind::Soft)},
      {test::soft(1.0)});
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  // The tip 0.1 mm into the floor; the shank (1 mm radius from z = 3.5) 0.2 mm into the wall.
  const Pose g = probe_at(Vec3(1.7, 0.0, kTip - 0.1));
  test::collect(m, s, g, 0.01);
  build_regions(m, s.constants, s.pairs, s.regions);
  ASSERT_GE(s.regions.count, 2);
  EXPECT_EQ(s.regions.pairs, s.pairs.count);
  for (int j = 1; j < s.regions.pairs; ++j)
    EXPECT_LE(s.pairs.geometry[s.regions.order[j - 1]].gap, s.pairs.geometry[s.regions.order[j]].gap);
  int floor_regions = 0;
  for (int r = 0; r < s.regions.count; ++r) {
    const Region& reg = s.regions.regions[r];
    EXPECT_TRUE(reg.compliant);
    EXPECT_EQ(reg.gap, s.pairs.geometry[reg.pair].gap);
    EXPECT_EQ(reg.tip, reg.object == 0) << "the floor's region holds the tip, the wall's the shank";
    floor_regions += reg.object == 0;
    for (int q = 0; q < r; ++q) {
      const Region& other = s.regions.regions[q];
      if (other.object == reg.object) {
        EXPECT_GE((other.tool_point_local - reg.tool_point_local).norm(), kRegionRadius);
      }
    }
  }
  EXPECT_EQ(floor_regions, 1);
  // Every pair belongs to the first region of its object near its tool point, and is no deeper than
  // the pair that founded it.
  for (int i = 0; i < s.pairs.count; ++i) {
    const int r = s.regions.pair_region[i];
    ASSERT_GE(r, 0) << i;
    const Region& reg = s.regions.regions[r];
    EXPECT_EQ(reg.object, s.pairs.refs[i].object);
    EXPECT_LT((reg.tool_point_local - s.constants.leaf_local[s.pairs.refs[i].tool_leaf]).norm(),
              kRegionRadius);
    EXPECT_GE(s.pairs.geometry[i].gap, reg.gap);
  }
  int f = 0;
  while (s.regions.regions[f].object != 0) ++f;
  const Region& floor = s.regions.regions[f];
  EXPECT_NEAR(floor.gap, -0.1, 1e-6);
  EXPECT_NEAR((floor.normal - Vec3::UnitZ()).norm(), 0.0, 1e-7);
}

// Issue #11: many pairs are sorted by buckets instead of std::sort; the pairs must come out in exactly
// the order std::sort gives (the rows and regions follow it), for any count, with distinct gaps, with
// equal ones (std::sort orders those its own way) and with gaps that are not finite.
TEST(BuildRegions, OrdersThePairsAsStdSortWould) {
  const Model m = slab_model(test::soft(1.0), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  test::collect(m, s, probe_at(Vec3(0.0, 0.0, kTip - 0.1)), 0.01);
  ASSERT_GT(s.pairs.count, 0);
  const PairRef ref = s.pairs.refs[0];
  const PairGeometry geo = s.pairs.geometry[0];
  std::mt19937 rng(5);
  std::normal_distribution<double> gap(0.0, 0.2);  // mm
  const std::array<int, 9> counts{1, 2, 16, 31, 32, 33, 100, 260, kMaxPairs};
  int sorted_with_ties = 0;
  for (int kind = 0; kind < 4; ++kind) {
    for (const int n : counts) {
      s.pairs.count = n;
      for (int i = 0; i < n; ++i) {
        s.pairs.refs[i] = ref;
        s.pairs.geometry[i] = geo;
        double& g = s.pairs.geometry[i].gap;
        g = gap(rng);
        if (kind == 1) g = std::round(g * 50.0) / 50.0;  // many equal gaps
        if (kind == 2 && i % 7 == 3) g = s.pairs.geometry[i / 2].gap;  // a few
        if (kind == 3 && i == n / 2) g = i % 2 == 0 ? std::numeric_limits<double>::infinity() : -1e300;
      }
      std::vector<std::pair<double, int>> want(static_cast<std::size_t>(n));
      for (int i = 0; i < n; ++i) want[static_cast<std::size_t>(i)] = {s.pairs.geometry[i].gap, i};
      std::sort(want.begin(), want.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      build_regions(m, s.constants, s.pairs, s.regions);
      bool ties = false;
      for (int j = 0; j < n; ++j) {
        EXPECT_EQ(s.regions.order[j], want[static_cast<std::size_t>(j)].second)
            << "kind " << kind << " n " << n << " position " << j;
        ties = ties || (j > 0 && want[static_cast<std::size_t>(j)].first == want[static_cast<std::size_t>(j - 1)].first);
      }
      sorted_with_ties += ties && n >= 32;
    }
  }
  EXPECT_GE(sorted_with_ties, 8) << "the equal gaps should reach the bucket sort";
}

// Issue #11: when more pairs qualify than kMaxPairs, collect_pairs orders them by (tool leaf, object,
// gap) by counting and insertion instead of std::sort; the order must be exactly std::sort's (the
// fair share and the rows follow it). Where std::sort's order is not unique (two equal or NaN gaps in
// one (tool leaf, object)) group_pairs must say so, so that collect_pairs sorts with std::sort.
TEST(CollectPairs, GroupsThePairsAsStdSortWould) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -2.0;
  spec.x1 = spec.y1 = 2.0;
  const auto leaves = test::slab(spec, [](const Vec3&) { return 0; });
  const Model m =
      test::model({test::object("a", leaves, ObjectKind::Soft), test::object("b", leaves, ObjectKind::Soft),
                   test::object("c", leaves, ObjectKind::Soft)},
                  {test::soft(1.0)});
  State state(m, probe_at(Vec3(0, 0, 5)));
  CollisionScratch& c = state_impl(state).collision;
  const auto tool_leaves = static_cast<int>(m.tool.tree.leaf_count());
  const int objects = static_cast<int>(m.objects.size());
  ASSERT_GT(tool_leaves, 4);
  std::mt19937 rng(11);
  std::normal_distribution<double> gap(0.0, 0.2);  // mm
  const std::array<std::size_t, 6> counts{1, 2, 17, 200, kMaxPairs + 1, c.contacts.capacity()};
  std::vector<uint32_t> order(c.contacts.capacity()), want(c.contacts.capacity());
  // kind 0: distinct gaps; 1: two equal gaps in one group; 2: equal gaps only across groups; 3: a NaN.
  for (int kind = 0; kind < 4; ++kind) {
    for (const std::size_t n : counts) {
      c.contacts.clear();
      for (std::size_t i = 0; i < n; ++i) {
        Contact con;
        con.object_node = static_cast<uint32_t>(i);
        con.tool_leaf = static_cast<uint16_t>(rng() % static_cast<unsigned>(tool_leaves));
        con.object = static_cast<uint16_t>(rng() % static_cast<unsigned>(objects));
        con.gap = gap(rng);
        if (kind == 2) {  // group i % 7, gap by i / 7: equal gaps in different groups only
          con.tool_leaf = static_cast<uint16_t>((i % 7) / 3 + 1);
          con.object = static_cast<uint16_t>((i % 7) % 3);
          con.gap = 0.01 * static_cast<double>(i / 7);
        }
        if (kind == 1 && i == n - 1 && n > 1) {  // the same group and gap as the first pair
          con.tool_leaf = c.contacts[0].tool_leaf;
          con.object = c.contacts[0].object;
          con.gap = c.contacts[0].gap;
        }
        if (kind == 3 && i == n / 2) {  // in the first pair's group, unless it is the first pair
          con.gap = std::numeric_limits<double>::quiet_NaN();
          if (i > 0) con.tool_leaf = c.contacts[0].tool_leaf, con.object = c.contacts[0].object;
        }
        c.contacts.push(con);
      }
      ASSERT_EQ(c.contacts.size(), n);
      for (std::size_t i = 0; i < n; ++i) want[i] = static_cast<uint32_t>(i);
      std::sort(want.begin(), want.begin() + static_cast<std::ptrdiff_t>(n), [&](uint32_t a, uint32_t b) {
        const Contact& x = c.contacts[a];
        const Contact& y = c.contacts[b];
        if (x.tool_leaf != y.tool_leaf) return x.tool_leaf < y.tool_leaf;
        if (x.object != y.object) return x.object < y.object;
        return x.gap < y.gap;
      });
      const bool exact = group_pairs(c, n, std::span<uint32_t>(order.data(), n));
      const bool unique = kind == 0 || kind == 2 || (kind == 1 && n == 1) || (kind == 3 && n == 1);
      EXPECT_EQ(exact, unique) << "kind " << kind << " n " << n;
      if (!exact) continue;
      for (std::size_t j = 0; j < n; ++j)
        ASSERT_EQ(order[j], want[j]) << "kind " << kind << " n " << n << " position " << j;
    }
  }
}

// Rigid contact rows: the linearised gap n·dp + (a × n)·dθ >= -gap, rigid (no compliance), keyed in
// the contact key space, at most kMaxRowsPerGroup per (tool leaf, object) with distinct normals.
TEST(ContactRows, RigidRowsAreTheLinearisedGap) {
  const Model m = slab_model(test::enamel(), ObjectKind::Rigid);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  const Pose g{Vec3(0.05, 0.0, kTip + 0.005), Quat(Eigen::AngleAxisd(0.2, Vec3::UnitX()))};
  test::collect(m, s, g, 0.05);
  build_regions(m, s.constants, s.pairs, s.regions);
  s.rows.clear(Mat6::Identity(), Vec6::Zero());
  const int added = build_contact_rows(m, m.defaults, s.pairs, s.regions, false, s.contact_rows, s.rows);
  ASSERT_GT(added, 0);
  EXPECT_EQ(added, s.rows.contacts);
  EXPECT_EQ(added, s.rows.problem.row_count);
  std::set<uint64_t> keys;
  std::map<std::pair<int, int>, std::vector<Vec3>> per_group;
  for (int r = 0; r < s.rows.problem.row_count; ++r) {
    const QpRow& row = s.rows.problem.rows[r];
    const RowMeta& meta = s.rows.meta[r];
    ASSERT_EQ(meta.kind, RowKind::Contact);
    const PairGeometry& geo = s.pairs.geometry[meta.pair];
    const PairRef& ref = s.pairs.refs[meta.pair];
    EXPECT_EQ(Vec3(row.a.head<3>()), geo.normal);
    EXPECT_EQ(Vec3(row.a.tail<3>()), geo.lever.cross(geo.normal));
    EXPECT_EQ(row.b, -geo.gap);
    EXPECT_EQ(row.compliance, 0.0);
    EXPECT_FALSE(row.equality);
    EXPECT_EQ(row.key, contact_key(ref));
    EXPECT_EQ(meta.region, s.regions.pair_region[meta.pair]);
    keys.insert(row.key);
    per_group[{ref.tool_leaf, ref.object}].push_back(geo.normal);
  }
  EXPECT_EQ(keys.size(), static_cast<std::size_t>(added)) << "one key per row";
  for (const auto& [group, normals] : per_group) {
    EXPECT_LE(normals.size(), static_cast<std::size_t>(kMaxRowsPerGroup));
    for (std::size_t a = 0; a < normals.size(); ++a)
      for (std::size_t b = a + 1; b < normals.size(); ++b)
        EXPECT_LE(normals[a].dot(normals[b]), kRigidNormalCos);
  }
  // Inside the tunnel (hold_only) a rigid row never asks to move out of an overlap.
  const Pose sunk = probe_at(Vec3(0.0, 0.0, kTip - 0.02));
  test::collect(m, s, sunk, 0.05);
  build_regions(m, s.constants, s.pairs, s.regions);
  s.rows.clear(Mat6::Identity(), Vec6::Zero());
  build_contact_rows(m, m.defaults, s.pairs, s.regions, true, s.contact_rows, s.rows);
  ASSERT_GT(s.rows.problem.row_count, 0);
  for (int r = 0; r < s.rows.problem.row_count; ++r) EXPECT_LE(s.rows.problem.rows[r].b, 0.0);
}

// A compliant region gives one row per surface direction however many spheres overlap: the tip
// pressed into a flat soft slab has one row, along the plane's normal, of compliance 1/k.
TEST(ContactRows, CompliantRegionGivesOneRowPerDirection) {
  const double k = 0.8;  // N/mm
  const Model m = slab_model(test::soft(k), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  test::collect(m, s, probe_at(Vec3(0.03, 0.02, kTip - 0.3)), 0.01);
  build_regions(m, s.constants, s.pairs, s.regions);
  ASSERT_GT(s.pairs.count, 20) << "many spheres overlap";
  ASSERT_EQ(s.regions.count, 1);
  s.rows.clear(Mat6::Identity(), Vec6::Zero());
  ASSERT_EQ(build_contact_rows(m, m.defaults, s.pairs, s.regions, false, s.contact_rows, s.rows), 1);
  const QpRow& row = s.rows.problem.rows[0];
  EXPECT_NEAR((Vec3(row.a.head<3>()) - Vec3::UnitZ()).norm(), 0.0, 1e-7);
  EXPECT_NEAR(row.b, 0.3, 1e-6);
  EXPECT_DOUBLE_EQ(row.compliance, 1.0 / k);
}

// A hand-made pair for the row builder: object 0's leaf `leaf` (in leaf order) against `tool_leaf`,
// `depth` mm deep (negative: clear) along the unit `normal`, its patch `lateral` mm sideways of the tool
// leaf (infinite: measured sphere against sphere).
struct GivenPair {
  int leaf;
  uint16_t tool_leaf;
  double depth;
  Vec3 normal;
  double lateral = 0.01;
  bool carried = false;
};

// Lists `given` as the pairs of `s` (at the origin), builds the regions and the contact rows, and
// returns each row's compliance (mm/N) by its pair's index in `given`.
std::map<int, double> contact_rows_of(const Model& m, StateImpl& s, const std::vector<GivenPair>& given) {
  s.pairs.count = 0;
  s.pairs.at = probe_at(Vec3(0, 0, 0));
  for (const GivenPair& g : given) {
    PairRef& ref = s.pairs.refs[s.pairs.count];
    ref = PairRef{m.objects[0].tree.leaf_nodes[static_cast<std::size_t>(g.leaf)], g.tool_leaf, 0, false};
    ref.carried = g.carried;
    PairGeometry& geo = s.pairs.geometry[s.pairs.count++];
    geo.normal = g.normal;
    geo.lever = Vec3::Zero();
    geo.wall = geo.internal = false;
    geo.gap = -g.depth;
    geo.lateral = g.lateral;
  }
  build_regions(m, s.constants, s.pairs, s.regions);
  EXPECT_EQ(s.regions.count, 1);
  s.rows.clear(Mat6::Identity(), Vec6::Zero());
  build_contact_rows(m, m.defaults, s.pairs, s.regions, false, s.contact_rows, s.rows);
  std::map<int, double> out;
  for (int r = 0; r < s.rows.problem.row_count; ++r) {
    EXPECT_EQ(s.rows.meta[r].kind, RowKind::Contact);
    out[s.rows.meta[r].pair] = s.rows.problem.rows[r].compliance;
  }
  return out;
}

std::set<int> pairs_of(const std::map<int, double>& rows) {
  std::set<int> out;
  for (const auto& [pair, compliance] : rows) out.insert(pair);
  return out;
}

// Hysteresis of the compliant rows (issue #11: in a soft fissure the tool chattered between a pose
// where a wall's direction had a row and one where the election left it out): a pair that bore load
// at the last solve (carried) keeps a row of its own while it overlaps, unless its region already
// has a row of a similar direction or it lies deeper than pass 2's depth rule allows. Here one
// compliant region holds more surface directions than the kMaxRowsPerGroup the election keeps.
TEST(ContactRows, ACarriedPairKeepsItsDirectionsRow) {
  const Model m = slab_model(test::soft(1.0), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  ASSERT_EQ(kMaxRowsPerGroup, 3);
  // All of the tip's leaf, on patches.
  const std::vector<GivenPair> given = {
      {0, 0, 0.20, Vec3(0.0, -0.6, 0.8)},                // 0: founds the region, too deep for a row
      {1, 0, 0.10, Vec3(0.0, 0.0, 1.0)},                 // 1: elected, a row
      {2, 0, 0.09, Vec3(0.6, 0.0, 0.8)},                 // 2: elected, a row
      {3, 0, 0.08, Vec3(-0.6, 0.0, 0.8)},                // 3: a fourth direction: the group is full
      {4, 0, 0.06, Vec3(0.1, 0.0, 0.995).normalized()},  // 4: 6 degrees from pair 1's direction
      {5, 0, -0.01, Vec3(0.0, 0.6, 0.8)}};               // 5: clear of the surface
  const auto rows_for = [&](int carried) {
    std::vector<GivenPair> pairs = given;
    if (carried >= 0) pairs[static_cast<std::size_t>(carried)].carried = true;
    const std::map<int, double> rows = contact_rows_of(m, s, pairs);
    for (const auto& [pair, compliance] : rows) EXPECT_DOUBLE_EQ(compliance, 1.0) << "pair " << pair;
    return pairs_of(rows);
  };
  // The election keeps pairs 0, 1 and 2; pass 2 gives rows to those within kCompliantDepthSlack of
  // the shallowest (0.09 mm), and 0 is deeper than twice that.
  EXPECT_EQ(rows_for(-1), (std::set<int>{1, 2}));
  // Carried, the fourth direction gets its row back.
  EXPECT_EQ(rows_for(3), (std::set<int>{1, 2, 3}));
  // Not a pair whose direction already has a row of its tool leaf, nor one too deep for the depth
  // rule, nor one that no longer overlaps.
  EXPECT_EQ(rows_for(4), (std::set<int>{1, 2}));
  EXPECT_EQ(rows_for(0), (std::set<int>{1, 2}));
  EXPECT_EQ(rows_for(5), (std::set<int>{1, 2}));
}

// Of two pairs of a similar direction the deeper tool leaf's elects, unless the other one's row bore
// load at the last solve (carried): then it keeps the vote, so that two tool leaves about as deep do
// not take turns at choosing the surface.
TEST(ContactRows, ACarriedPairKeepsItsDirectionsVote) {
  const Model m = slab_model(test::soft(1.0), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  ASSERT_GE(s.constants.tool_leaves, 2u);
  const auto elected = [&](bool carried) {
    return pairs_of(contact_rows_of(m, s, {{0, 1, 0.06, Vec3(0, 0, 1)},  // tool leaf 1, deeper, up
                                           {1, 0, 0.05, Vec3(0.1, 0.0, 0.995).normalized(), 0.01, carried}}));
  };
  EXPECT_EQ(elected(false), (std::set<int>{0}));
  EXPECT_EQ(elected(true), (std::set<int>{1}));
}

// Pass 2's depth rule is continuous: a compliant direction within kCompliantDepthSlack of the
// shallowest pushes with the tissue's stiffness, a deeper one with a share that falls linearly to
// none at twice the slack.
TEST(ContactRows, ADirectionPastTheDepthSlackFadesOut) {
  ASSERT_DOUBLE_EQ(kCompliantDepthSlack, 0.05);
  EXPECT_DOUBLE_EQ(compliant_depth_fade(0.0, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(compliant_depth_fade(0.15, 0.1), 1.0);
  EXPECT_NEAR(compliant_depth_fade(0.175, 0.1), 0.5, 1e-12);
  EXPECT_NEAR(compliant_depth_fade(0.19, 0.1), 0.2, 1e-12);
  EXPECT_EQ(compliant_depth_fade(0.2, 0.1), 0.0);
  EXPECT_EQ(compliant_depth_fade(0.3, 0.1), 0.0);

  const double k = 0.5;  // N/mm
  const Model m = slab_model(test::soft(k), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  // All of the tip's leaf, on patches, three directions.
  std::map<int, double> compliance = contact_rows_of(m, state_impl(state),
                                                     {{0, 0, 0.20, Vec3(0.0, -0.6, 0.8)},   // past the fade
                                                      {1, 0, 0.125, Vec3(0.6, 0.0, 0.8)},   // half way
                                                      {2, 0, 0.05, Vec3(0.0, 0.0, 1.0)}});  // the shallowest
  EXPECT_EQ(pairs_of(compliance), (std::set<int>{1, 2}));
  EXPECT_NEAR(compliance[1], 2.0 / k, 1e-9);
  EXPECT_NEAR(compliance[2], 1.0 / k, 1e-9);
}

// Rigid rows are deduplicated per (tool leaf, object): a pair within kRigidNormalCos of a deeper
// pair's direction gets no row, unless it is carried (it bore load at the last solve while its tool
// leaf's quota was full). The step carries only such rigid pairs, and every loaded compliant one.
TEST(ContactRows, ACarriedRigidPairOfACappedLeafKeepsItsRow) {
  const Model m = slab_model(test::enamel(), ObjectKind::Rigid);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  const SphereTree& tree = m.objects[0].tree;
  const Vec3 tilted = Vec3(0.1, 0.0, 0.995).normalized();  // 6 degrees from the deeper pair's normal
  ASSERT_GT(tilted.z(), kRigidNormalCos);
  const double sphere = std::numeric_limits<double>::infinity();  // measured sphere against sphere
  const auto build = [&](bool carried) {
    const std::vector<GivenPair> given = {{0, 0, 0.004, Vec3::UnitZ(), sphere},
                                          {1, 0, 0.002, tilted, sphere, carried}};
    return pairs_of(contact_rows_of(m, s, given));
  };
  EXPECT_EQ(build(false), (std::set<int>{0}));
  EXPECT_EQ(build(true), (std::set<int>{0, 1}));

  // Both rows loaded: the rigid pair is remembered only when its (tool leaf, object) was capped.
  ASSERT_EQ(s.rows.problem.row_count, 2);
  s.solution.qp.lambda.fill(0.0);
  s.solution.qp.lambda[0] = s.solution.qp.lambda[1] = 0.5;
  const std::vector<ContactSet::Capped> none, capped = {{0, 0}}, other_leaf = {{1, 0}};
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, false, none, s.carried);
  EXPECT_EQ(s.carried.count, 0);
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, false, other_leaf, s.carried);
  EXPECT_EQ(s.carried.count, 0);
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, false, capped, s.carried);
  ASSERT_EQ(s.carried.count, 2);
  EXPECT_EQ(s.carried.refs[1].object_node, tree.leaf_nodes[1]);
  EXPECT_FALSE(s.carried.refs[1].carried);  // remembered as a plain reference
  // Nothing inside a tunnel, and nothing whose row bore no load.
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, true, capped, s.carried);
  EXPECT_EQ(s.carried.count, 0);
  s.solution.qp.lambda[1] = 0.0;
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, false, capped, s.carried);
  ASSERT_EQ(s.carried.count, 1);
  EXPECT_EQ(s.carried.refs[0].object_node, tree.leaf_nodes[0]);
}

// The step carries the compliant pairs that bore load to its next solve, and forgets them in free
// space.
TEST(Solve, TheStepCarriesLoadedCompliantPairsAndForgetsThemInFreeSpace) {
  const Model m = slab_model(test::soft(0.5), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  for (int i = 0; i < 50; ++i) step(m, state, HapticInput{probe_at(Vec3(0, 0, kTip - 0.5)), 0.001});
  ASSERT_GT(s.carried.count, 0);
  for (int c = 0; c < s.carried.count; ++c) {
    bool loaded = false;
    for (int r = 0; r < s.rows.problem.row_count; ++r) {
      const RowMeta& meta = s.rows.meta[r];
      loaded = loaded || (meta.kind == RowKind::Contact && s.solution.qp.lambda[r] > 0.0 &&
                          s.pairs.refs[meta.pair].object_node == s.carried.refs[c].object_node &&
                          s.pairs.refs[meta.pair].tool_leaf == s.carried.refs[c].tool_leaf);
    }
    EXPECT_TRUE(loaded) << "carried pair " << c << " bore no load at the last solve";
  }
  for (int i = 0; i < 5; ++i) step(m, state, HapticInput{probe_at(Vec3(0, 0, 3)), 0.001});
  EXPECT_EQ(s.carried.count, 0);
}

// A sphere pressed onto a compliant plane, the stages end to end: the tip sits `depth` below the
// surface and the hand `push` further down; the multiplier is the series spring force
// (depth + push) / (1/k_t + 1/k), the region carries it, the coupling balances it and the tool sinks
// below the surface by force / k.
TEST(Solve, SphereOnACompliantPlane) {
  const double k = 0.5, k_t = 1.0, depth = 0.2, push = 0.6;  // N/mm, N/mm, mm, mm
  const Model m = slab_model(test::soft(k), ObjectKind::Soft);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  test::collect(m, s, probe_at(Vec3(0, 0, kTip - depth)), 0.01);
  build_regions(m, s.constants, s.pairs, s.regions);
  Mat6 G = Mat6::Identity() * k_t;
  G.diagonal().tail<3>().setConstant(150.0);
  Vec6 target = Vec6::Zero();
  target.z() = -push;
  s.rows.clear(G, target);
  build_contact_rows(m, m.defaults, s.pairs, s.regions, false, s.contact_rows, s.rows);
  solve_rows(s.rows, s.regions, s.solver, s.solution);
  EXPECT_EQ(s.solution.flags, 0u);
  EXPECT_EQ(s.solution.qp.status, QpStatus::Optimal);
  const double force = (depth + push) / (1.0 / k_t + 1.0 / k);
  EXPECT_NEAR(s.solution.region_force[0], force, 1e-9);
  EXPECT_NEAR(s.solution.d.z(), -push + force / k_t, 1e-9);
  EXPECT_NEAR(depth - s.solution.d.z(), force / k, 1e-9);
  EXPECT_NEAR(s.solution.d.head<2>().norm() + s.solution.d.tail<3>().norm(), 0.0, 1e-9);
}

// Contradicting rigid rows: the solve stage reports infeasible and moves nothing, with no force.
TEST(Solve, InfeasibleRowsMoveNothing) {
  RowSet rows;
  RegionSet regions;
  regions.count = 1;
  Vec6 target = Vec6::Zero();
  target.x() = 0.3;
  rows.clear(Mat6::Identity(), target);
  QpRow right, left;
  right.a.x() = 1.0;
  right.b = 1.0;  // x >= 1
  left.a.x() = -1.0;
  left.b = 0.0;  // x <= 0
  ASSERT_TRUE(rows.add(right, RowMeta{RowKind::Contact, 0, -1, 0}));
  ASSERT_TRUE(rows.add(left, RowMeta{RowKind::Contact, 0, -1, 1}));
  QpSolver solver;
  Solution solution;
  solve_rows(rows, regions, solver, solution);
  EXPECT_EQ(solution.qp.status, QpStatus::Infeasible);
  EXPECT_TRUE(solution.flags & kFlagInfeasible);
  EXPECT_EQ(solution.d, Vec6::Zero());
  EXPECT_EQ(solution.region_force[0], 0.0);
}

// Every QP status but Optimal raises a flag; the two capacity statuses have their own.
TEST(Solve, EveryStatusButOptimalRaisesAFlag) {
  EXPECT_EQ(flags_of(QpStatus::Optimal), 0u);
  EXPECT_EQ(flags_of(QpStatus::Infeasible), static_cast<uint32_t>(kFlagInfeasible));
  EXPECT_EQ(flags_of(QpStatus::BadInput), static_cast<uint32_t>(kFlagInfeasible));
  EXPECT_EQ(flags_of(QpStatus::ActiveSetFull), static_cast<uint32_t>(kFlagQpActiveSetFull));
  EXPECT_EQ(flags_of(QpStatus::IterationLimit), static_cast<uint32_t>(kFlagQpIterationLimit));
}

// A full row set says so and keeps what it holds.
TEST(RowSet, ReportsWhenFull) {
  RowSet rows;
  rows.clear(Mat6::Identity(), Vec6::Zero());
  for (int i = 0; i < kQpMaxRows; ++i) ASSERT_TRUE(rows.add(QpRow{}, RowMeta{}));
  EXPECT_FALSE(rows.full);
  EXPECT_FALSE(rows.add(QpRow{}, RowMeta{}));
  EXPECT_TRUE(rows.full);
  EXPECT_EQ(rows.problem.row_count, kQpMaxRows);
  rows.clear(Mat6::Identity(), Vec6::Zero());
  EXPECT_FALSE(rows.full);
  EXPECT_EQ(rows.problem.row_count, 0);
}

// The three row builders' key spaces never meet.
TEST(RowKeys, KeySpacesAreDisjoint) {
  std::set<uint64_t> keys;
  std::size_t n = 0;
  for (uint16_t object : {0, 1, 63})
    for (uint16_t leaf : {0, 1, 65535})
      for (uint32_t node : {0u, 7u, 0xFFFFFFFFu})
        keys.insert(contact_key(PairRef{node, leaf, object, false})), ++n;
  for (int anchor = 0; anchor < kMaxAnchors; ++anchor)
    for (int tangent = 0; tangent < 2; ++tangent) keys.insert(friction_key(anchor, tangent)), ++n;
  for (TunnelRow row : {TunnelRow::Lateral0, TunnelRow::Lateral1, TunnelRow::Rotation0, TunnelRow::Rotation1,
                        TunnelRow::Rotation2, TunnelRow::Bottom, TunnelRow::Hold})
    keys.insert(tunnel_key(row)), ++n;
  EXPECT_EQ(keys.size(), n);
}

}  // namespace
}  // namespace cariesim
