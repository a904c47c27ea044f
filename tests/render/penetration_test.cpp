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
#include "cariesim/scene/model_builder.hpp"
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

// One insertion at a constant hand speed: the hand comes down along the axis from 1 mm above the
// surface at `speed` mm/s for `seconds`. Per step: the apex depth and the axial force felt (the wrench
// pushes the hand back up, +z).
struct Insertion {
  std::vector<double> depth;  ///< mm
  std::vector<double> force;  ///< N, along +z
  std::vector<InteractionState> state;
  /// Mean axial force (N) over the steps inside the lesion with the depth in [from, to) mm.
  double mean_force(double from, double to) const {
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < depth.size(); ++i)
      if (state[i] == InteractionState::Inserting && depth[i] >= from && depth[i] < to) sum += force[i], ++n;
    EXPECT_GT(n, 10) << "too few steps with the depth in [" << from << ", " << to << ") mm";
    return n > 0 ? sum / n : 0.0;
  }
};

Insertion insert_at_speed(const Model& m, double speed, double seconds, double rate = 1000.0) {
  const double top = top_of(m) + m.tool.tip_radius;
  Trajectory t;
  t.add(0.0, upright(m, top + 1.0));
  t.add(seconds, upright(m, top + 1.0 - speed * seconds));
  Insertion out;
  for (const SimSample& s : simulate(m, t, rate)) {
    out.depth.push_back(s.out.depth);
    out.force.push_back(s.out.force.z());
    out.state.push_back(s.out.state);
  }
  return out;
}

// A caries material on the blocks: the preset's, with k_e 1 N/mm unless the preset is kept whole.
Model blocks_with(const Material& caries) {
  Model m = blocks();
  Material& c = caries_of(m);
  const int16_t lesion = c.lesion;
  c = caries;
  c.lesion = lesion;
  return m;
}

// The felt axial force while inserting at 2 mm/s (a hand's clinical speed): the presets differ by
// far more than 25 %, and so does k_c alone (the paper's Table 2 finding that dentists tell mild from
// severe by k_c). On main before the crush-length model both plateaued at F_p*.
TEST(Penetration, KcIsFeltAtAHandsSpeed) {
  const Material mild = caries_preset(CariesPreset::Mild), severe = caries_preset(CariesPreset::Severe);
  const double f_mild = insert_at_speed(blocks_with(mild), 2.0, 5.0).mean_force(0.5, 2.0);
  const double f_severe = insert_at_speed(blocks_with(severe), 2.0, 5.0).mean_force(0.5, 2.0);
  EXPECT_GT(f_mild, 1.25 * f_severe) << "mild " << f_mild << " N, severe " << f_severe << " N";
  // The felt force is the tissue's resistance through the tunnel's coupling: R · k_p / k_e (eq. 6).
  const double k_p = blocks().defaults.limits.max_stiffness;
  EXPECT_NEAR(f_mild, insertion_resistance(mild, 1.0) * k_p / mild.k_e, 0.1 * f_mild);

  // k_c alone: everything else the same (k_e, F_p*, crush length), k_c 0.58 against 0.20 N/mm. With
  // the mild F_p* (2 N) and R(0) = 0.6 N the soft one's breakthrough gives way until the apex is
  // about 2.7 mm below the surface, so its force is compared deeper, before the shank meets the
  // healthy block at 4.7 mm.
  Material firm = mild, soft = mild;
  soft.k_c.values.fill(0.20);
  const double f_firm = insert_at_speed(blocks_with(firm), 2.0, 5.0).mean_force(3.0, 4.3);
  const double f_soft = insert_at_speed(blocks_with(soft), 2.0, 5.0).mean_force(3.0, 4.3);
  EXPECT_GT(f_firm, 1.25 * f_soft) << "k_c 0.58: " << f_firm << " N, k_c 0.20: " << f_soft << " N";
  // And at 1 and 5 mm/s the same force: the model is quasi-static.
  const double f_slow = insert_at_speed(blocks_with(firm), 1.0, 9.0).mean_force(0.5, 2.0);
  const double f_fast = insert_at_speed(blocks_with(firm), 5.0, 1.8).mean_force(0.5, 2.0);
  EXPECT_NEAR(f_slow, f_firm, 0.05 * f_firm);
  EXPECT_NEAR(f_fast, f_firm, 0.05 * f_firm);
}

// Fig. 6, double layer: the felt force steps at the layer boundary, by the ratio of k_c.
TEST(Penetration, LayerBoundaryStepsTheForce) {
  Material c = caries_preset(CariesPreset::Mild);
  c.k_e = 1.0;
  c.f_p_star = 0.5;  // N: below R(0), so the tip does not give way at the breakthrough
  c.k_c.kind = KcProfile::Kind::Layers;
  c.k_c.layer_count = 2;
  c.k_c.values = {0.3, 0.6, 0.6, 0.6};  // N/mm: a softer layer over a firmer one
  c.k_c.bounds = {1.5, 50.0, 0.0, 0.0};
  const Insertion in = insert_at_speed(blocks_with(c), 2.0, 3.5);
  const double before = in.mean_force(0.9, 1.4), after = in.mean_force(1.6, 2.1);
  EXPECT_GE(after - before, 0.25 * before) << "before " << before << " N, after " << after << " N";
  EXPECT_NEAR(after / before, 2.0, 0.2);
  // A step, not a ramp: the change happens within 0.1 mm of the boundary.
  EXPECT_NEAR(in.mean_force(1.35, 1.48), before, 0.05 * before);
  EXPECT_NEAR(in.mean_force(1.52, 1.65), after, 0.05 * after);

  // A firmer layer over a softer one steps down as much: the tip gives way at the boundary (at
  // max_give_speed) until the hand's push has fallen to the softer layer's resistance.
  c.k_c.values = {0.6, 0.3, 0.3, 0.3};
  const Insertion down = insert_at_speed(blocks_with(c), 2.0, 4.5);
  EXPECT_NEAR(down.mean_force(2.6, 3.2) / down.mean_force(0.9, 1.4), 0.5, 0.05);
}

// Fig. 6, non-homogeneous: a gradient gives a monotone ramp of the felt force, without a step.
TEST(Penetration, GradientGivesAMonotoneRamp) {
  Material c = caries_preset(CariesPreset::Mild);
  c.k_e = 1.0;
  c.f_p_star = 0.5;  // N: below R(0), so the tip does not give way at the breakthrough
  c.k_c.kind = KcProfile::Kind::Gradient;
  c.k_c.values = {0.2, 0.8, 0.0, 0.0};
  c.k_c.bounds = {3.0, 0.0, 0.0, 0.0};
  const Insertion in = insert_at_speed(blocks_with(c), 2.0, 4.5);
  double last = 0.0;
  for (double d = 0.4; d < 2.8; d += 0.3) {
    const double f = in.mean_force(d, d + 0.3);
    EXPECT_GT(f, last + 0.05) << "no rise at " << d << " mm";
    last = f;
  }
  // Between steps the force changes by little more than the ramp itself (no knocks).
  double largest = 0.0;
  for (std::size_t i = 1; i < in.force.size(); ++i)
    if (in.state[i] == InteractionState::Inserting && in.state[i - 1] == InteractionState::Inserting &&
        in.depth[i] > 0.4)
      largest = std::max(largest, std::abs(in.force[i] - in.force[i - 1]));
  EXPECT_LT(largest, 0.02);
}

// The same hand motion at 1 kHz and 4 kHz ends at the same depth and force (2 %).
TEST(Penetration, InsertionDoesNotDependOnTheServoRate) {
  const Model m = blocks_with(caries_preset(CariesPreset::Mild));
  const Insertion slow = insert_at_speed(m, 3.0, 2.5, 1000.0), fast = insert_at_speed(m, 3.0, 2.5, 4000.0);
  ASSERT_GT(slow.depth.back(), 1.0);
  EXPECT_NEAR(fast.depth.back(), slow.depth.back(), 0.02 * slow.depth.back());
  EXPECT_NEAR(fast.force.back(), slow.force.back(), 0.02 * slow.force.back());
  EXPECT_NEAR(fast.mean_force(0.3, 1.0), slow.mean_force(0.3, 1.0), 0.02 * slow.mean_force(0.3, 1.0));
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
    inside += penetrating(out.state);
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
  const ObjectMask rigid = rigid_objects(m);
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
    const bool inside = penetrating(out.state);
    const bool was_inside = penetrating(last);
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
