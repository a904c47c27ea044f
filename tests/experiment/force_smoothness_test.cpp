// Issue #10: a device plays a large force change between two servo steps as a knock. On a raster
// over a real molar (FDI 36 between 35 and 37, scanned; the haptic tip 2 mm below the surface at
// 20 mm/s, scenes/trajectories/real-raster-36.csv) the rendered force changes by at most 1 N from one
// 1 ms step to the next, first touches out of free space aside.
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;

TEST(ForceSmoothness, RasterOverARealMolarHasNoKnocks) {
  const fs::path data = fs::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / "tooth_19.ply";
  if (!fs::exists(data)) GTEST_SKIP() << "shipped scan missing: " << data;
  const fs::path root(CARIESIM_SOURCE_DIR);
  const Model model = build_model(load_scene((root / "scenes/examples/real-molar-36.yaml").string()));
  const Trajectory raster = load_trajectory_csv(root / "scenes/trajectories/real-raster-36.csv");
  const std::vector<SimSample> samples = simulate(model, raster, 1000.0);
  double largest = 0.0, at = 0.0, peak = 0.0;
  int touching = 0;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    peak = std::max(peak, samples[i].out.force.norm());
    touching += samples[i].out.state != InteractionState::Free;
    if (samples[i - 1].out.state == InteractionState::Free) continue;
    const double change = (samples[i].out.force - samples[i - 1].out.force).norm();
    if (change > largest) largest = change, at = samples[i].t;
  }
  ASSERT_GT(touching, 3000) << "the raster should run over the tooth";
  ASSERT_GT(peak, 1.0) << "the tip 2 mm below the surface should press";
  EXPECT_LE(largest, 1.0) << "a force step of " << largest << " N at t = " << at << " s";
}

}  // namespace
}  // namespace cariesim
