// TimedCapture (servo/servo.hpp): the servo thread takes the graphic tool at given servo times, in
// ascending order whatever order they were given in, each at the first cycle at or after its time,
// without allocating.
#include <gtest/gtest.h>

#include <vector>

#include "cariesim/servo/servo.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

Pose at_x(double x) {
  Pose p;
  p.p = Vec3(x, 0.0, 0.0);
  return p;
}

TEST(TimedCapture, TakesEachTimeAtTheFirstCycleReachingIt) {
  TimedCapture capture({0.3, 0.1, 0.2, 0.2});
  ASSERT_EQ(capture.times(), (std::vector<double>{0.1, 0.2, 0.2, 0.3}));
  const std::size_t before = test::allocation_count();
  capture.take(0.05, at_x(1.0), 0);
  EXPECT_EQ(capture.taken(), 0u);
  capture.take(0.1, at_x(2.0), 1);
  EXPECT_EQ(capture.taken(), 1u);
  capture.take(0.25, at_x(3.0), 2);  // both 0.2 s entries, in one cycle
  EXPECT_EQ(capture.taken(), 3u);
  capture.take(0.26, at_x(4.0), 0);
  capture.take(0.301, at_x(5.0), 0);
  capture.take(0.5, at_x(6.0), 0);  // nothing left: nothing changes
  EXPECT_EQ(test::allocation_count(), before) << "take() allocates nothing";
  ASSERT_EQ(capture.taken(), 4u);
  const double t[] = {0.1, 0.25, 0.25, 0.301};
  const double x[] = {2.0, 3.0, 3.0, 5.0};
  const int contacts[] = {1, 2, 2, 0};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(capture.entry(i).t, t[i]) << i;
    EXPECT_DOUBLE_EQ(capture.entry(i).graphic.p.x(), x[i]) << i;
    EXPECT_EQ(capture.entry(i).contacts, contacts[i]) << i;
  }
}

}  // namespace
}  // namespace cariesim
