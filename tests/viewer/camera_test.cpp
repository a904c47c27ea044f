// The orbit camera (apps/viewer/camera.cpp): framing, projection, screen axes, limits, the occlusal
// preset past the handle.
#include "viewer/camera.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace {

using cariesim::Vec3;
using cariesim::viewer::CameraPreset;
using cariesim::viewer::kOcclusalClearance;
using cariesim::viewer::OrbitCamera;
using cariesim::viewer::ToolSection;

// The target projects to the centre of the viewport; the eye is `distance` away from it.
TEST(OrbitCamera, TargetProjectsToTheCentre) {
  OrbitCamera camera;
  camera.target = Vec3(3.0, -2.0, 5.0);
  camera.distance = 80.0;
  camera.yaw = 0.4;
  camera.pitch = 0.3;
  Eigen::Vector2d px;
  ASSERT_TRUE(camera.project(camera.target, 800.0, 600.0, px));
  EXPECT_NEAR(px.x(), 400.0, 1e-9);
  EXPECT_NEAR(px.y(), 300.0, 1e-9);
  EXPECT_NEAR((camera.eye() - camera.target).norm(), 80.0, 1e-9);
}

// Right, up and forward are orthonormal and right-handed (right x up = -forward, toward the eye).
TEST(OrbitCamera, ScreenAxesAreOrthonormal) {
  OrbitCamera camera;
  for (const double yaw : {-2.0, 0.0, 1.0}) {
    for (const double pitch : {-1.0, 0.0, 0.7}) {
      camera.yaw = yaw;
      camera.pitch = pitch;
      EXPECT_NEAR(camera.right().norm(), 1.0, 1e-12);
      EXPECT_NEAR(camera.up().norm(), 1.0, 1e-12);
      EXPECT_NEAR(camera.right().dot(camera.forward()), 0.0, 1e-12);
      EXPECT_NEAR(camera.up().dot(camera.forward()), 0.0, 1e-12);
      EXPECT_TRUE(camera.right().cross(camera.up()).isApprox(-camera.forward(), 1e-12));
      EXPECT_GT(camera.up().z(), 0.0) << "the scene's +z is up on the screen";
    }
  }
}

// A world step of mm_per_pixel along the screen's right axis moves the projection by one pixel.
TEST(OrbitCamera, MillimetresPerPixelMatchTheProjection) {
  OrbitCamera camera;
  camera.distance = 120.0;
  const Vec3 p = camera.target + camera.forward() * 10.0;
  const double depth = (p - camera.eye()).dot(camera.forward());
  const double mm = camera.mm_per_pixel(depth, 700.0);
  Eigen::Vector2d a, b, c;
  ASSERT_TRUE(camera.project(p, 1000.0, 700.0, a));
  ASSERT_TRUE(camera.project(p + camera.right() * (25.0 * mm), 1000.0, 700.0, b));
  ASSERT_TRUE(camera.project(p + camera.up() * (25.0 * mm), 1000.0, 700.0, c));
  EXPECT_NEAR(b.x() - a.x(), 25.0, 1e-6);
  EXPECT_NEAR(b.y() - a.y(), 0.0, 1e-6);
  EXPECT_NEAR(c.y() - a.y(), -25.0, 1e-6) << "up on the screen is toward smaller pixel rows";
}

// After framing, the box fills the view: its corners spread over most of it and stray at most a
// little past its edges; a point behind the eye does not project.
TEST(OrbitCamera, FrameFillsTheViewWithTheBox) {
  OrbitCamera camera;
  const Eigen::AlignedBox3d box(Vec3(-30, -20, -15), Vec3(35, 25, 10));
  camera.frame(box);
  EXPECT_TRUE(camera.target.isApprox(box.center()));
  Eigen::AlignedBox2d extent;
  for (int i = 0; i < 8; ++i) {
    Eigen::Vector2d px;
    ASSERT_TRUE(
        camera.project(box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(i)), 800.0, 800.0, px));
    extent.extend(px);
  }
  EXPECT_GT(extent.sizes().maxCoeff(), 400.0);
  EXPECT_GT(extent.min().minCoeff(), -0.15 * 800.0);
  EXPECT_LT(extent.max().maxCoeff(), 1.15 * 800.0);
  Eigen::Vector2d px;
  EXPECT_FALSE(camera.project(camera.eye() - camera.forward(), 800.0, 800.0, px));
}

// The view matrix maps the eye to the origin and the target onto -z at `distance`.
TEST(OrbitCamera, ViewMatrixLooksDownMinusZ) {
  OrbitCamera camera;
  camera.target = Vec3(1, 2, 3);
  camera.distance = 50.0;
  const Eigen::Vector4f eye = camera.view() * Eigen::Vector4f(static_cast<float>(camera.eye().x()),
                                                              static_cast<float>(camera.eye().y()),
                                                              static_cast<float>(camera.eye().z()), 1.0f);
  const Eigen::Vector4f target = camera.view() * Eigen::Vector4f(1, 2, 3, 1);
  EXPECT_NEAR(eye.head<3>().norm(), 0.0, 1e-4);
  EXPECT_NEAR(target.z(), -50.0, 1e-4);
  EXPECT_NEAR(target.x(), 0.0, 1e-4);
  // The projection puts the target between the clip planes.
  const Eigen::Vector4f clip = camera.projection(1.5) * target;
  EXPECT_LT(std::abs(clip.z() / clip.w()), 1.0f);
}

// Orbiting keeps the pitch within ±89°; zooming stays within [1 mm, 2 m] and ignores bad factors.
TEST(OrbitCamera, OrbitAndZoomLimits) {
  OrbitCamera camera;
  camera.orbit(0.0, 10.0);
  EXPECT_NEAR(camera.pitch, 89.0 * M_PI / 180.0, 1e-12);
  camera.orbit(0.0, -20.0);
  EXPECT_NEAR(camera.pitch, -89.0 * M_PI / 180.0, 1e-12);
  camera.distance = 10.0;
  camera.zoom(1e-6);
  EXPECT_DOUBLE_EQ(camera.distance, 1.0);
  camera.zoom(1e9);
  EXPECT_DOUBLE_EQ(camera.distance, 2000.0);
  camera.zoom(std::nan(""));
  camera.zoom(-2.0);
  EXPECT_DOUBLE_EQ(camera.distance, 2000.0);
}

// The occlusal preset looks past the explorer's handle: a handle standing straight up from the tip
// (4.5 mm radius, from 7 mm to 120 mm) hides the tip from the preset's usual direction (5° off the
// vertical), so the camera tilts until its line of sight clears the handle by the preset's 12°, the
// least tilt that does; a handle lying away to the side leaves the usual direction as it is.
TEST(OrbitCamera, OcclusalPresetLooksPastTheHandle) {
  const Vec3 tip(10.0, 20.0, 5.0);
  std::vector<ToolSection> upright, sideways;
  for (double s = 0.0; s <= 120.0; s += 2.0) {
    upright.push_back({tip + Vec3(0.0, 0.0, s), s < 7.0 ? 0.3 : 4.5});
    sideways.push_back({tip + Vec3(s, 0.0, 0.2 * s), s < 7.0 ? 0.3 : 4.5});
  }
  OrbitCamera camera;
  camera.look(CameraPreset::Occlusal, tip, Vec3::Zero());
  EXPECT_LT(camera.tool_clearance(upright), 0.0) << "the handle hides the tip from the usual direction";

  camera.look(CameraPreset::Occlusal, tip, Vec3::Zero(), 45.0, upright);
  EXPECT_GE(camera.tool_clearance(upright), kOcclusalClearance);
  EXPECT_TRUE(camera.target.isApprox(tip));
  // The least tilt: the handle's angular radius at its nearest counted section plus the clearance,
  // to the next 5° step; the view still from above.
  const double needed = kOcclusalClearance + std::asin(4.5 / 8.0);
  EXPECT_LE(M_PI / 2.0 - camera.pitch, needed + 5.0 * M_PI / 180.0 + 1e-9);
  EXPECT_GE(camera.pitch, 30.0 * M_PI / 180.0);

  camera.look(CameraPreset::Occlusal, tip, Vec3::Zero(), 45.0, sideways);
  EXPECT_NEAR(camera.yaw, 0.0, 1e-12);
  EXPECT_NEAR(camera.pitch, 85.0 * M_PI / 180.0, 1e-12);
  EXPECT_TRUE(std::isinf(camera.tool_clearance({})));
}

}  // namespace
