// The servo step allocates nothing (docs/style.md "Model / State / step"): count every global operator new
// around many steps that exercise free motion, sliding with friction, and slips.
#include <gtest/gtest.h>

#include "cariesim/render/step.hpp"
#include "render/render_support.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

TEST(StepAllocations, ManyStepsAllocateNothing) {
  test::SlabSpec spec;
  const Model m = test::model(
      {test::object("soft", test::slab(spec, [](const Vec3& p) { return p.x() < 0 ? 0 : 1; }), ObjectKind::Soft)},
      {test::soft(1.0, 0.6, 0.3, Tissue::Caries), test::soft(2.0)});
  State s(m, test::probe_at(Vec3(-4, 0, 2)));
  step(m, s, HapticInput{test::probe_at(Vec3(-4, 0, 2)), 0.001});  // warm up outside the window

  const std::size_t before = test::allocation_count();
  int slips = 0, sliding = 0;
  for (int i = 0; i < 4000; ++i) {
    const double x = -4.0 + 8.0 * i / 4000.0;
    const double z = i < 300 ? 2.0 - 2.5 * i / 300.0 : -0.5;  // free, then pressing and sliding
    const StepOutput out = step(m, s, HapticInput{test::probe_at(Vec3(x, 0.2, z)), 0.001});
    slips += out.slips;
    sliding += out.state == InteractionState::Sliding;
  }
  EXPECT_EQ(test::allocation_count() - before, 0u);
  EXPECT_GT(slips, 3);       // the window did exercise friction
  EXPECT_GT(sliding, 3000);  // and contact
}

}  // namespace
}  // namespace cariesim
