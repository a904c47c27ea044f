#include "cariesim/device/trajectory_csv.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cariesim/common/error.hpp"
#include "support/fifo.hpp"

namespace cariesim {
namespace {

std::string error_of(std::string_view text) {
  try {
    parse_trajectory_csv(text, "traj.csv");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Trajectory, ParsesAndInterpolates) {
  const Trajectory tr = parse_trajectory_csv(
      "t,px,py,pz,qw,qx,qy,qz\n"
      "0,0,0,0,1,0,0,0\n"
      "# a comment\n"
      "1.0,10,0,-2,0.7071067811865476,0,0,0.7071067811865476\n",
      "traj.csv");
  ASSERT_EQ(tr.t.size(), 2u);
  const Pose mid = tr.sample(0.5);
  EXPECT_NEAR(mid.p.x(), 5.0, 1e-12);
  EXPECT_NEAR(mid.p.z(), -1.0, 1e-12);
  // Slerp halfway through a 90 degree turn about z is 45 degrees.
  EXPECT_NEAR(rotation_vector(mid.q).z(), M_PI / 4.0, 1e-9);
  EXPECT_NEAR(tr.sample(-1.0).p.x(), 0.0, 1e-12);  // clamped before the start
  EXPECT_NEAR(tr.sample(9.0).p.x(), 10.0, 1e-12);  // and after the end
}

TEST(Trajectory, ColumnsInAnyOrderAndQuaternionsNormalised) {
  // Rounding (a quaternion written with six digits) is normalised away.
  const Trajectory tr =
      parse_trajectory_csv("qw,qx,qy,qz,t,px,py,pz,extra\n1.0004,0,0,0,0,1,2,3,x\n", "traj.csv");
  EXPECT_NEAR(tr.pose[0].q.w(), 1.0, 1e-12);
  EXPECT_NEAR(tr.pose[0].p.y(), 2.0, 1e-12);
}

// A non-unit quaternion is judged as the UDP bridge judges it (not silently normalised): unit within
// kUnitTolerance (is_unit), else an error at its line and column.
TEST(Trajectory, NonUnitQuaternionsAreRejectedAsByTheBridge) {
  const std::string e = error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,0,0,2,0,0,0\n");
  EXPECT_NE(e.find("traj.csv:3:9: quaternion (qw,qx,qy,qz) has length 2"), std::string::npos) << e;
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,0.5,0.5,0.5,0.4\n").find("unit quaternion"),
            std::string::npos);
}

// A UTF-8 byte order mark before the header is skipped (the header does not "lack column 't'").
TEST(Trajectory, AByteOrderMarkIsSkipped) {
  const Trajectory tr =
      parse_trajectory_csv("\xEF\xBB\xBFt,px,py,pz,qw,qx,qy,qz\n0,1,2,3,1,0,0,0\n", "traj.csv");
  ASSERT_EQ(tr.t.size(), 1u);
  EXPECT_EQ(tr.pose[0].p.x(), 1.0);
}

// A directory given as a trajectory (sim --trajectory, scripted:DIR) is named as a folder, not
// reported as an "empty trajectory".
TEST(Trajectory, ADirectoryIsNamedAsSuch) {
  const auto dir = std::filesystem::temp_directory_path();
  try {
    load_trajectory_csv(dir);
    FAIL() << "a directory loaded as a trajectory";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("trajectory (CSV t,px,py,pz,qw,qx,qy,qz): not a regular file (a folder)"),
        std::string::npos)
        << e.what();
  }
}

// A FIFO as a trajectory (`sim --trajectory`, `--device scripted:FIFO`), which would block the reader
// forever, and /dev/zero, which never ends, are refused at once without reading, naming their kind.
TEST(Trajectory, AFifoOrADeviceIsRefusedWithoutReading) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("cariesim_traj_fifo_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto fifo = dir / "path.csv";
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::FifoOutcome outcome = test::read_fifo(fifo, [fifo] { (void)load_trajectory_csv(fifo); });
  EXPECT_FALSE(outcome.blocked) << "load_trajectory_csv blocked on a FIFO";
  EXPECT_NE(outcome.error.find("not a regular file (a FIFO (named pipe))"), std::string::npos)
      << outcome.error;
  try {
    (void)load_trajectory_csv("/dev/zero");
    FAIL() << "/dev/zero loaded as a trajectory";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("/dev/zero: trajectory (CSV t,px,py,pz,qw,qx,qy,qz): not a regular file "
                                   "(a character device)"),
        std::string::npos)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

// Every text input is bounded: a trajectory file over kMaxTrajectoryBytes (a sparse file here) is
// refused by its size before a byte is read, and a line of zeros by its length.
TEST(Trajectory, TheFileAndItsLinesAreBounded) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("cariesim_traj_big_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto big = dir / "big.csv";
  std::ofstream(big) << "t,px,py,pz,qw,qx,qy,qz\n";
  std::filesystem::resize_file(big, kMaxTrajectoryBytes + 1);
  try {
    (void)load_trajectory_csv(big);
    FAIL() << "an oversized trajectory loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("too large (1073741825 bytes, at most 1073741824)"),
              std::string::npos)
        << e.what();
  }
  const auto zeros = dir / "zeros.csv";
  std::ofstream(zeros) << "t,px,py,pz,qw,qx,qy,qz\n";
  std::filesystem::resize_file(zeros, 8u << 20);
  try {
    (void)load_trajectory_csv(zeros);
    FAIL() << "a line of 8 MB loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("line 2 is longer than 1048576 bytes"), std::string::npos)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(Trajectory, CursorMatchesSample) {
  Trajectory tr;
  for (int i = 0; i <= 10; ++i)
    tr.add(0.1 * i, Pose{Vec3(i * i, 0, 0), Quat(Eigen::AngleAxisd(0.1 * i, Vec3::UnitX()))});
  TrajectoryCursor cursor(tr);
  for (double t = -0.05; t < 1.1; t += 0.013) {
    const Pose a = cursor.at(t), b = tr.sample(t);
    EXPECT_NEAR((a.p - b.p).norm(), 0.0, 1e-12) << t;
    EXPECT_NEAR(a.q.angularDistance(b.q), 0.0, 1e-12) << t;
  }
}

TEST(Trajectory, ErrorsNameLineColumnAndField) {
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy\n0,0,0,0,1,0,0\n").find("lacks column 'qz'"), std::string::npos);
  const std::string bad_number = error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,abc,0,1,0,0,0\n");
  EXPECT_NE(bad_number.find("traj.csv:2:5"), std::string::npos) << bad_number;
  EXPECT_NE(bad_number.find("'py'"), std::string::npos) << bad_number;
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,nan,0,1,0,0,0\n").find("not finite"), std::string::npos);
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,0,0,0,0\n").find("has length 0"), std::string::npos);
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n1,0,0,0,1,0,0,0\n1,0,0,0,1,0,0,0\n").find("traj.csv:3:1: time"),
            std::string::npos);
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n0,0,0\n").find("expected 8 fields"), std::string::npos);
  EXPECT_NE(error_of("").find("empty"), std::string::npos);
  EXPECT_NE(error_of("t,px,py,pz,qw,qx,qy,qz\n").find("no samples"), std::string::npos);
}

}  // namespace
}  // namespace cariesim
