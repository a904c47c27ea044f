// The one playback (common/trajectory.hpp): the normalised blend, the loop rule, the cursor's search
// from a hint (equal to a search from the start), a loop's seam, the segment velocities.
#include "cariesim/common/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace cariesim {
namespace {

// A run of samples with a loop's seam: indices from 100, two loops of the same three poses.
struct Looped {
  std::vector<double> times;
  std::vector<Pose> poses;
  [[nodiscard]] std::uint64_t first() const { return 100; }
  [[nodiscard]] std::uint64_t end() const { return 100 + times.size(); }
  [[nodiscard]] double time(std::uint64_t i) const { return times[i - 100]; }
  [[nodiscard]] const Pose& pose(std::uint64_t i) const { return poses[i - 100]; }
};

Pose pose_at(double x, double angle) {
  Pose p;
  p.p = Vec3(x, 0.0, 0.0);
  p.q = Quat(Eigen::AngleAxisd(angle, Vec3::UnitZ()));
  return p;
}

TEST(Playback, BlendIsUnitAndLinear) {
  const Pose a = pose_at(0.0, 0.0);
  const Pose b = pose_at(4.0, 0.8);
  const Pose mid = blend(a, b, 0.25);
  EXPECT_DOUBLE_EQ(mid.p.x(), 1.0);
  EXPECT_NEAR(mid.q.angularDistance(Quat(Eigen::AngleAxisd(0.2, Vec3::UnitZ()))), 0.0, 1e-9);
  // A little off unit length, as a file from elsewhere may be: still a unit quaternion between them.
  Pose long_a = a;
  Pose short_b = b;
  long_a.q.coeffs() *= 1.0009;
  short_b.q.coeffs() *= 0.9992;
  const Pose off = blend(long_a, short_b, 0.25);
  EXPECT_NEAR(off.q.norm(), 1.0, 1e-15);
  EXPECT_LT(off.q.angularDistance(mid.q), 1e-3);
}

TEST(Playback, OneLoopRule) {
  EXPECT_DOUBLE_EQ(playback_offset(2.5, 2.0, false), 2.5);
  EXPECT_DOUBLE_EQ(playback_offset(2.5, 2.0, true), 0.5);  // the period is the duration
  EXPECT_DOUBLE_EQ(playback_offset(2.0, 2.0, true), 0.0);  // the last sample's time starts the next loop
  EXPECT_DOUBLE_EQ(playback_offset(-1.0, 2.0, true), 0.0);
  EXPECT_DOUBLE_EQ(playback_offset(std::nan(""), 2.0, false), 0.0);
  EXPECT_DOUBLE_EQ(playback_offset(7.0, 0.0, true), 0.0);  // one sample
}

TEST(Playback, CursorFromAHintEqualsASearchFromTheStart) {
  Trajectory tr;
  for (int i = 0; i <= 200; ++i) tr.add(0.01 * i, pose_at(0.1 * i, 0.01 * i));
  TrajectoryCursor walking(tr);
  // Forward in small and large steps (a bisection past 16 samples), then back.
  for (const double time : {-1.0, 0.0, 0.005, 0.01, 0.0333, 0.5, 1.2345, 1.24, 1.9999, 2.0, 3.0, 0.7, 0.01}) {
    TrajectoryCursor fresh(tr);
    const Pose a = walking.at(time);
    const Pose b = fresh.at(time);
    EXPECT_EQ(a.p, b.p) << time;
    EXPECT_EQ(a.q.coeffs(), b.q.coeffs()) << time;
    EXPECT_LT((a.p - tr.sample(time).p).norm(), 1e-12) << time;
  }
}

TEST(Playback, SeamVelocitiesAndRingIndices) {
  // Two loops of a 2 s trajectory, unrolled: the second loop's first sample plays at 2 s, as the
  // first loop's last one does.
  Looped run;
  for (int loop = 0; loop < 2; ++loop)
    for (int i = 0; i <= 2; ++i) {
      run.times.push_back(2.0 * loop + i);
      run.poses.push_back(pose_at(10.0 * i, 0.0));
    }
  PlaybackCursor<Looped> cursor;
  EXPECT_DOUBLE_EQ(cursor.at(run, 1.5).p.x(), 15.0);
  EXPECT_EQ(cursor.at_or_before(), 101u);
  EXPECT_DOUBLE_EQ(cursor.velocity(run).linear.x(), 10.0);  // mm/s over the segment
  // At the seam the next loop's first pose plays, with its segment's velocity.
  EXPECT_DOUBLE_EQ(cursor.at(run, 2.0).p.x(), 0.0);
  EXPECT_EQ(cursor.at_or_before(), 103u);
  EXPECT_DOUBLE_EQ(cursor.velocity(run).linear.x(), 10.0);
  EXPECT_DOUBLE_EQ(cursor.at(run, 2.5).p.x(), 5.0);
  // Past the end: the last pose, no velocity.
  EXPECT_DOUBLE_EQ(cursor.at(run, 9.0).p.x(), 20.0);
  EXPECT_EQ(cursor.velocity(run).linear, Vec3::Zero());
}

}  // namespace
}  // namespace cariesim
