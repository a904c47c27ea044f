// The plot's history (apps/viewer/force_history.cpp): resampling, restarts, the ring's capacity.
#include "viewer/force_history.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace {

using cariesim::Vec3;
using cariesim::viewer::ForceHistory;
using Series = ForceHistory::Series;

// The value at each grid time is that of the latest sample at or before it.
TEST(ForceHistory, ResamplesTheLatestValueBeforeEachGridTime) {
  ForceHistory h(4.0);
  h.add(0.0, Vec3(1, 0, 0), Vec3::Zero());
  h.add(1.5, Vec3(0, 2, 0), Vec3(0, 0, 3));
  h.add(4.0, Vec3(0, 0, -4), Vec3::Zero());
  std::vector<float> v;
  h.resample(Series::ForceNorm, 5, v);  // grid 0, 1, 2, 3, 4 s
  EXPECT_EQ(v, (std::vector<float>{1, 1, 2, 2, 4}));
  h.resample(Series::Fz, 5, v);
  EXPECT_EQ(v, (std::vector<float>{0, 0, 0, 0, -4}));
  h.resample(Series::TorqueNorm, 5, v);
  EXPECT_EQ(v, (std::vector<float>{0, 0, 3, 3, 0}));
  EXPECT_FLOAT_EQ(h.max_in_window(Series::ForceNorm), 4.0f);
}

// A clock that goes back (a restarted loop) starts over; a repeated time adds nothing.
TEST(ForceHistory, RestartAndRepeats) {
  ForceHistory h(5.0);
  h.add(10.0, Vec3(1, 0, 0), Vec3::Zero());
  h.add(10.0, Vec3(9, 0, 0), Vec3::Zero());
  EXPECT_EQ(h.size(), 1u);
  h.add(0.5, Vec3(2, 0, 0), Vec3::Zero());
  EXPECT_EQ(h.size(), 1u);
  std::vector<float> v;
  h.resample(Series::Fx, 2, v);
  EXPECT_EQ(v, (std::vector<float>{0, 2}));
}

// Beyond the capacity the oldest samples go; an empty history plots zeros.
TEST(ForceHistory, RingDropsTheOldest) {
  ForceHistory h(100.0, 4);
  std::vector<float> v;
  h.resample(Series::Fx, 3, v);
  EXPECT_EQ(v, (std::vector<float>{0, 0, 0}));
  for (int i = 0; i < 10; ++i) h.add(i, Vec3(i, 0, 0), Vec3::Zero());
  EXPECT_EQ(h.size(), 4u);
  h.resample(Series::Fx, 1, v);
  EXPECT_EQ(v, (std::vector<float>{9}));
  EXPECT_FLOAT_EQ(h.max_in_window(Series::Fx), 9.0f);
  h.resample(Series::Fx, 101, v);
  EXPECT_EQ(v[0], 0.0f) << "before the oldest kept sample";
  EXPECT_EQ(v[100 - 3], 6.0f);
}

}  // namespace
