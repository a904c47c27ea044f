#pragma once
// Shared by the servo and device tests: the built-in friction-block scene's model (built once per
// process, from the default tree cache), a trajectory that presses onto its caries top and slides,
// and a wait helper that fails instead of hanging.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>

#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim::test {

/// The friction-block model: a 60 x 20 x 10 mm compliant block (top at z = 0) whose top is caries.
inline const Model& friction_block() {
  static const Model model = build_model(load_scene("friction-block"));
  return model;
}

/// The home pose moved to `p` (mm): the tip lowest, the handle rising toward +x.
inline Pose home_at(const Model& model, const Vec3& p) { return Pose{p, model.tool_home.q}; }

/// From the home pose down onto the block (tip `press` mm below the top), then sliding along +x.
inline Trajectory press_and_slide(const Model& model, double press = 0.5, double slide_seconds = 2.0) {
  Trajectory tr;
  const Vec3 home = model.tool_home.p;
  tr.add(0.0, model.tool_home);
  tr.add(0.3, home_at(model, Vec3(home.x(), home.y(), -press)));
  tr.add(0.3 + slide_seconds, home_at(model, Vec3(home.x() + 20.0, home.y(), -press)));
  return tr;
}

/// Polls `done` every millisecond; false after `limit` (a failure, not a timing assertion: it only
/// keeps a broken test from hanging).
inline bool wait_for(const std::function<bool()>& done,
                     std::chrono::seconds limit = std::chrono::seconds(30)) {
  const auto give_up = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace cariesim::test
