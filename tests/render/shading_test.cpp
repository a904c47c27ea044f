// Force shading (docs/step.md, "Force shading"): on the scanned arch the rendered force is turned
// from the rigid rows' sphere normals to the scan's normals at the contact points, its magnitude kept,
// while the tool moves exactly as without shading; and the step stays allocation-free with it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "cariesim/render/step.hpp"
#include "render/render_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

// The hand pressing 0.3 mm into 46's enamel beside real-arch's lesion #1 and sliding 1.5 mm there and
// back, the explorer along the lesion's outward normal, at 1 kHz.
std::vector<Pose> slide_beside_lesion1(const Model& m) {
  const LesionModel& l = m.lesions.front();
  const Vec3 n = l.shape.normal.normalized(), s = l.shape.center;
  const Vec3 side = n.unitOrthogonal();
  const Quat q = Quat::FromTwoVectors(Vec3::UnitZ(), n);
  const auto at = [&](double u, double depth) {
    return Pose{s + side * u - n * (depth - m.tool.tip_radius), q};
  };
  std::vector<Pose> out;
  for (int k = 0; k < 500; ++k) out.push_back(at(2.0, -1.0 + 1.3 * k / 499.0));
  for (int k = 0; k < 1500; ++k) out.push_back(at(2.0 + 1.5 * k / 1499.0, 0.3));
  for (int k = 0; k < 1500; ++k) out.push_back(at(3.5 - 1.5 * k / 1499.0, 0.3));
  return out;
}

struct SlideRun {
  std::vector<StepOutput> out;
  std::size_t allocations = 0;
};

SlideRun run_slide(bool shading) {
  Model m = test::real_arch();
  m.settings.force_shading = shading;
  const std::vector<Pose> hand = slide_beside_lesion1(m);
  State s(m, hand.front());
  step(m, s, HapticInput{hand.front(), 0.001});  // warm up outside the window
  SlideRun r;
  r.out.reserve(hand.size());
  const std::size_t before = test::allocation_count();
  for (const Pose& h : hand) r.out.push_back(step(m, s, HapticInput{h, 0.001}));
  r.allocations = test::allocation_count() - before;
  return r;
}

TEST(ForceShading, TurnsTheForceOnlyWhileTheToolMovesAsWithoutIt) {
  const SlideRun off = run_slide(false), on = run_slide(true);
  ASSERT_EQ(off.out.size(), on.out.size());
  int touching = 0, turned = 0;
  double largest = 0.0;  // degrees
  for (std::size_t i = 0; i < on.out.size(); ++i) {
    const StepOutput& a = off.out[i];
    const StepOutput& b = on.out[i];
    ASSERT_EQ(a.graphic.p, b.graphic.p) << i;  // bit for bit: the rows are the sphere pairs'
    ASSERT_EQ(a.graphic.q.coeffs(), b.graphic.q.coeffs()) << i;
    ASSERT_EQ(a.state, b.state) << i;
    EXPECT_NEAR(a.force.norm(), b.force.norm(), 1e-9) << i;  // turned, not scaled
    EXPECT_TRUE(b.force.allFinite()) << i;
    if (a.contacts == 0 || a.force.norm() < 0.05) {
      EXPECT_EQ(a.force, b.force) << i;  // nothing to turn
      continue;
    }
    ++touching;
    const double angle = std::acos(std::clamp(a.force.normalized().dot(b.force.normalized()), -1.0, 1.0)) *
                         180.0 / 3.14159265358979323846;
    largest = std::max(largest, angle);
    turned += angle > 0.5;
  }
  std::printf("force shading: %d steps touching, %d turned by more than 0.5 degrees, at most %.2f degrees\n",
              touching, turned, largest);
  EXPECT_GT(touching, 2500);        // the slide is in contact
  EXPECT_GT(turned, touching / 4);  // and shading turns the force on much of it
  EXPECT_LT(largest, 15.0);         // never beyond the sphere normal's lean (pairs.cpp)
}

TEST(ForceShading, TheShadedStepAllocatesNothing) {
  // The allocation counter around 3 500 steps on the scan with shading (their outputs kept in a
  // vector reserved beforehand).
  const SlideRun on = run_slide(true);
  EXPECT_EQ(on.allocations, 0u);
}

}  // namespace
}  // namespace cariesim
