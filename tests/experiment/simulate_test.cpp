// simulate(), simulate_each() and the step count (experiment/simulate.hpp): issue #14 item 5, a run's
// memory does not grow with its length, and an absurd span is an error instead of an allocation
// failure or a wrapped-around step count.
#include "cariesim/experiment/simulate.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// A small rigid block (coarse octree, quick to build) in a cache folder of its own.
Model small_block() {
  const fs::path cache = fs::temp_directory_path() / ("cariesim_simulate_" + std::to_string(::getpid()));
  BuildOptions options;
  options.cache_dir = cache;
  Model model = build_model(parse_scene(R"(objects:
  - name: block
    shape: {type: cuboid, size: [6, 6, 4]}
    tree: {mode: octree, depth: 3}
)",
                                        "block.yaml"),
                            options);
  fs::remove_all(cache);
  return model;
}

// A straight pass over the block's top, `seconds` long.
Trajectory pass(const Model& model, double seconds) {
  Trajectory t;
  const Quat q = model.tool_home.q;
  t.add(0.0, Pose{Vec3(-2.0, 0.0, 2.5), q});
  t.add(seconds, Pose{Vec3(2.0, 0.0, 1.9), q});
  return t;
}

// Before the fix every step's 1.6 KB SimSample was kept until the end of the run (1M steps, 1.6 GB).
// Now the steps stream through: a run ten times longer makes no more allocations.
TEST(Simulate, StreamingAllocatesTheSameHoweverLongTheRun) {
  const Model model = small_block();
  std::size_t rows = 0;
  const auto count_allocations = [&](double seconds) {
    const Trajectory t = pass(model, seconds);
    const std::size_t before = test::allocation_count();
    rows += simulate_each(model, model.defaults, t, 1000.0, [](const SimSample&) {});
    return test::allocation_count() - before;
  };
  const std::size_t short_run = count_allocations(0.2);
  const std::size_t long_run = count_allocations(2.0);
  EXPECT_EQ(long_run, short_run) << "allocations grow with the run's length";
  EXPECT_EQ(rows, 201u + 2001u);
}

// A two-row trajectory spanning 1e7 s ended in bad_alloc; one spanning 1e300 s ran "1 steps" (the
// count wrapped). Both are refused, naming the span and the limit.
TEST(Simulate, AbsurdSpansAreRefused) {
  Trajectory t;
  t.add(0.0, Pose{});
  t.add(1e7, Pose{});
  try {
    (void)sim_step_count(t, 1000.0);
    FAIL() << "1e10 steps accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("spans 1e+07 s"));
    EXPECT_THAT(e.what(), HasSubstr("more than the 1e+08"));
  }
  Trajectory huge;
  huge.add(-1e300, Pose{});
  huge.add(1e300, Pose{});
  EXPECT_THROW((void)sim_step_count(huge, 1000.0), Error);
  Trajectory inf;
  inf.add(-1.7e308, Pose{});
  inf.add(1.7e308, Pose{});
  EXPECT_THROW((void)sim_step_count(inf, 1.0), Error);
  // The largest run allowed, and an ordinary one.
  Trajectory day;
  day.add(0.0, Pose{});
  day.add(9.9e4, Pose{});
  EXPECT_EQ(sim_step_count(day, 1000.0), 99000001u);
  Trajectory second;
  second.add(0.0, Pose{});
  second.add(1.0, Pose{});
  EXPECT_EQ(sim_step_count(second, 1000.0), 1001u);
}

}  // namespace
}  // namespace cariesim
