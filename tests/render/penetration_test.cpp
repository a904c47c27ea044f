// The penetration state on the real `insertion-blocks` scene (paper §3.3, §5.1): k_c profiles over
// depth (Fig. 6), rate independence of eq. 5, no allocation inside the tunnel, and a long seeded
// random session with frequent sliding/penetration switches that must stay finite, bounded and
// outside rigid tissue.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/experiment/simulate.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

constexpr double kTipX = -2.0;  // mm: where the probe enters the caries cube (as in the experiment)

const Model& blocks() {
  static const Model model = build_model(load_scene("insertion-blocks"));
  return model;
}

Material& caries_of(Model& m) { return m.defaults.materials[m.lesions.front().material]; }

double top_of(const Model& m) { return m.lesions.front().shape.center.z(); }

Pose upright(const Model&, double z) { return Pose{Vec3(kTipX, 0.0, z), Quat::Identity()}; }

// Presses straight down until the tip enters the lesion, then holds the hand `lag` mm below the
// graphic tip along the axis (a constant insertion force k_e·lag). Returns the depth per step.
std::vector<double> insert_with_constant_lag(const Model& m, double lag, int steps) {
  const double top = top_of(m) + m.tool.tip_radius;
  State s(m, upright(m, top + 2.0));
  double z = top + 2.0;
  int guard = 0;
  StepOutput out;
  while (out.state != InteractionState::Inserting && guard++ < 20000) {
    z -= 0.01;  // 10 mm/s
    out = step(m, s, HapticInput{upright(m, z), 0.001});
  }
  EXPECT_EQ(out.state, InteractionState::Inserting) << "never entered the lesion";
  std::vector<double> depth;
  for (int i = 0; i < steps; ++i) {
    out = step(m, s, HapticInput{upright(m, out.graphic.p.z() - lag), 0.001});
    depth.push_back(out.depth);
  }
  return depth;
}

// Mean depth growth per step (mm) while the depth lies in [from, to).
double speed_between(const std::vector<double>& depth, double from, double to) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 1; i < depth.size(); ++i)
    if (depth[i - 1] >= from && depth[i] < to) sum += depth[i] - depth[i - 1], ++n;
  return n > 0 ? sum / n : 0.0;
}

// Fig. 6, double layer: eq. 5's speed |F_p|/k_c jumps at the layer boundary by the ratio of k_c.
TEST(Penetration, LayersChangeTheSpeedAtTheirBoundary) {
  Model m = blocks();
  KcProfile& k = caries_of(m).k_c;
  k.kind = KcProfile::Kind::Layers;
  k.layer_count = 2;
  k.values = {2000.0, 500.0, 500.0, 500.0};  // N/mm, slow enough that k_c (not the hand) sets the pace
  k.bounds = {1.5, 50.0, 0.0, 0.0};
  const std::vector<double> depth = insert_with_constant_lag(m, 4.0, 1500);
  ASSERT_GT(depth.back(), 2.6);
  const double upper = speed_between(depth, 0.6, 1.4), lower = speed_between(depth, 1.7, 2.5);
  EXPECT_NEAR(upper, 4.0 / 2000.0, 2e-4);  // k_e 1 N/mm · 4 mm / k_c
  EXPECT_NEAR(lower / upper, 4.0, 0.4);
}

// Fig. 6, non-homogeneous: a gradient changes the speed smoothly (no jump between steps).
TEST(Penetration, GradientChangesTheSpeedSmoothly) {
  Model m = blocks();
  KcProfile& k = caries_of(m).k_c;
  k.kind = KcProfile::Kind::Gradient;
  k.values = {2000.0, 500.0, 500.0, 500.0};
  k.bounds = {3.0, 0.0, 0.0, 0.0};
  const std::vector<double> depth = insert_with_constant_lag(m, 4.0, 1200);
  ASSERT_GT(depth.back(), 2.5);
  double largest_change = 0.0;
  for (std::size_t i = 2; i < depth.size(); ++i) {
    if (depth[i] > 2.9) break;
    largest_change = std::max(largest_change, std::abs((depth[i] - depth[i - 1]) - (depth[i - 1] - depth[i - 2])));
  }
  EXPECT_LT(largest_change, 2e-4);  // mm per step²; a layer boundary of the same span jumps by 6e-3
  EXPECT_GT(speed_between(depth, 2.0, 2.8), 1.8 * speed_between(depth, 0.3, 1.0));
}

// Eq. 5 scaled by Δt / 1 ms: the same hand motion at 1 kHz and 4 kHz ends at the same depth (2 %).
TEST(Penetration, DepthDoesNotDependOnTheServoRate) {
  Model m = blocks();
  caries_of(m).k_c.values.fill(1500.0);  // k_c-limited, so the rate of eq. 5 matters
  const double top = top_of(m) + m.tool.tip_radius;
  Trajectory t;
  t.add(0.0, upright(m, top + 1.0));
  t.add(0.8, upright(m, top - 7.0));
  t.add(1.2, upright(m, top - 7.0));
  const std::vector<SimSample> slow = simulate(m, t, 1000.0);
  const std::vector<SimSample> fast = simulate(m, t, 4000.0);
  const double d1 = slow.back().out.depth, d4 = fast.back().out.depth;
  ASSERT_GT(d1, 1.0);
  EXPECT_NEAR(d4, d1, 0.02 * d1);
  // Halfway through the push as well.
  const double mid1 = slow[600].out.depth, mid4 = fast[2400].out.depth;
  EXPECT_NEAR(mid4, mid1, 0.02 * mid1 + 0.01);
}

// Inside the tunnel (with the additional contact on the healthy block) the step allocates nothing.
TEST(Penetration, TunnelStepsAllocateNothing) {
  const Model& m = blocks();
  const double top = top_of(m) + m.tool.tip_radius;
  State s(m, upright(m, top + 2.0));
  double z = top + 2.0;
  StepOutput out;
  for (int i = 0; i < 3000 && out.state != InteractionState::Inserting; ++i) {
    z -= 0.005;
    out = step(m, s, HapticInput{upright(m, z), 0.001});
  }
  ASSERT_EQ(out.state, InteractionState::Inserting);
  const std::size_t before = test::allocation_count();
  int inside = 0;
  for (int i = 0; i < 6000; ++i) {
    z += i < 4000 ? -0.002 : 0.004;  // deeper (the shank reaches the healthy block), then out
    out = step(m, s, HapticInput{upright(m, z), 0.001});
    inside += out.state == InteractionState::Inserting || out.state == InteractionState::Extracting;
  }
  EXPECT_EQ(test::allocation_count() - before, 0u);
  EXPECT_GT(inside, 3000);
}

// 100,000 seeded random steps over both blocks: pushes into the caries, pulls, slides and presses
// onto the rigid healthy block, with tilts. Never NaN, never over the force limit, never more than
// 0.01 mm inside rigid tissue; and the session does switch states often.
TEST(Penetration, RandomSessionStaysStable) {
  const Model& m = blocks();
  const double top = top_of(m) + m.tool.tip_radius;
  std::mt19937 rng(20161122u);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ObjectMask rigid = 0;
  for (std::size_t i = 0; i < m.objects.size(); ++i)
    if (m.objects[i].surface_only) rigid |= ObjectMask{1} << i;
  ASSERT_NE(rigid, 0u);
  PlacedTool placed(m.tool.tree);

  Pose from = upright(m, top + 2.0), to = from;
  State s(m, from);
  int segment_steps = 1, k = 0, entries = 0, exits = 0;
  InteractionState last = InteractionState::Free;
  double worst_overlap = 0.0, largest_force = 0.0;
  for (int i = 0; i < 100000; ++i) {
    if (k == segment_steps) {
      // A new segment: mostly straight down or up over the caries, sometimes sideways onto the
      // healthy block, with up to 15 degrees of tilt.
      from = to;
      const double x = unit(rng) < 0.7 ? kTipX + (unit(rng) - 0.5) : -8.0 + 13.0 * unit(rng);
      const double z = top + (unit(rng) < 0.6 ? -8.0 * unit(rng) : 2.0 * unit(rng));
      const Vec3 axis(0.26 * (unit(rng) - 0.5), 0.26 * (unit(rng) - 0.5), 1.0);
      to = Pose{Vec3(x, 2.0 * (unit(rng) - 0.5), z), Quat::FromTwoVectors(Vec3::UnitZ(), axis.normalized())};
      segment_steps = 50 + static_cast<int>(400 * unit(rng));
      k = 0;
    }
    ++k;
    const double a = static_cast<double>(k) / segment_steps;
    const Pose hand{from.p + a * (to.p - from.p), from.q.slerp(a, to.q)};
    const StepOutput out = step(m, s, HapticInput{hand, 0.001});
    ASSERT_TRUE(out.force.allFinite() && out.torque.allFinite() && out.graphic.p.allFinite()) << "step " << i;
    largest_force = std::max(largest_force, out.force.norm());
    const bool inside = out.state == InteractionState::Inserting || out.state == InteractionState::Extracting;
    const bool was_inside = last == InteractionState::Inserting || last == InteractionState::Extracting;
    entries += inside && !was_inside;
    exits += !inside && was_inside;
    last = out.state;
    placed.place(out.graphic, 0.0);
    const ClosestPair c = closest(placed, m.objects, rigid, 0.0);
    if (std::isfinite(c.gap)) worst_overlap = std::max(worst_overlap, -c.gap);
  }
  EXPECT_LE(largest_force, m.defaults.limits.max_force + 1e-9);
  EXPECT_LE(worst_overlap, m.settings.rigid_tolerance + 1e-9);
  EXPECT_GE(entries, 20);
  EXPECT_GE(exits, 20);
}

}  // namespace
}  // namespace cariesim
