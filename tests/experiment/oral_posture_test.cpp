// The interproximal lesion #2 of `oral-cavity` is reachable only with a correct posture (issue #4
// acceptance): leaning over the neighbour 45, the shank is stopped by that tooth and the tip never
// enters the lesion; with the searched posture it does.
#include <gtest/gtest.h>

#include <algorithm>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "experiment/oral.hpp"

namespace cariesim {
namespace {

struct ProbeResult {
  bool inserted = false;       // the tip entered the lesion
  bool neighbour_hit = false;  // a contact with the neighbouring tooth during the push
  double max_apex_depth = 0.0; // mm below the lesion's surface, along its normal
};

ProbeResult probe(const Model& model, int lesion_index, const Quat& q, int neighbour) {
  const LesionModel& lesion = model.lesions[lesion_index];
  double push_start = 0.0, push_end = 0.0;
  const Trajectory t = experiment::probe_trajectory(model, lesion, q, &push_start, &push_end);
  ProbeResult r;
  for (const SimSample& s : simulate(model, t, 1000.0)) {
    if (penetrating(s.out.state) && s.out.lesion == lesion_index) {
      r.inserted = true;
      r.max_apex_depth = std::max(r.max_apex_depth, experiment::apex_depth(model, lesion, s.out.graphic));
    }
    if (s.t < push_start || s.t > push_end) continue;
    for (int c = 0; c < s.out.contact_report_count; ++c)
      r.neighbour_hit = r.neighbour_hit || s.out.contact_reports[c].object == neighbour;
  }
  return r;
}

TEST(OralPosture, InterproximalLesionNeedsTheRightPosture) {
  const Model model = build_model(load_scene("oral-cavity"));
  int lesion = -1, neighbour = -1;
  for (std::size_t i = 0; i < model.lesions.size(); ++i)
    if (model.lesions[i].name == "lesion2") lesion = static_cast<int>(i);
  for (std::size_t i = 0; i < model.objects.size(); ++i)
    if (model.objects[i].name == "tooth45") neighbour = static_cast<int>(i);
  ASSERT_GE(lesion, 0);
  ASSERT_GE(neighbour, 0);

  // The searched posture is clear of everything and opens the lesion to its floor.
  const experiment::Posture good = experiment::best_posture(model, model.lesions[lesion]);
  EXPECT_GE(good.clearance, 0.3);
  const ProbeResult ok = probe(model, lesion, good.q, neighbour);
  EXPECT_TRUE(ok.inserted);
  EXPECT_NEAR(ok.max_apex_depth, model.lesions[lesion].authored_depth, 0.1);

  // The worst candidate whose shank runs into 45: stopped there, no insertion.
  const std::vector<experiment::Posture> all = experiment::posture_candidates(model, model.lesions[lesion]);
  const experiment::Posture* wrong = nullptr;
  for (const experiment::Posture& p : all)
    if (p.nearest_object == neighbour && (wrong == nullptr || p.clearance < wrong->clearance)) wrong = &p;
  ASSERT_NE(wrong, nullptr) << "no candidate posture comes near 45";
  EXPECT_LT(wrong->clearance, 0.0);
  const ProbeResult bad = probe(model, lesion, wrong->q, neighbour);
  EXPECT_TRUE(bad.neighbour_hit);
  EXPECT_FALSE(bad.inserted);
}

}  // namespace
}  // namespace cariesim
