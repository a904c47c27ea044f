// Events derived from the sample stream (src/record/event_deriver.cpp): each kind on a hand-made
// stream whose events are known, and the insert-then-update protocol of episodes.
#include "record/event_deriver.hpp"

#include <gtest/gtest.h>

#include <map>

#include "cariesim/device/safety.hpp"

namespace cariesim::record {
namespace {

constexpr double kPeriod = 0.001;  // s

// Feeds samples and keeps the latest version of every event by id, as the database would.
class Events {
 public:
  explicit Events(double threshold = 1.0) : deriver_(threshold, kPeriod) {}
  void add(const ServoSample& s) {
    deriver_.add(s);
    collect();
  }
  void finish() {
    deriver_.finish();
    collect();
  }
  // Events of one kind, by id (= creation order).
  std::vector<RecordedEvent> of(const std::string& kind) const {
    std::vector<RecordedEvent> out;
    for (const auto& [id, e] : rows_)
      if (e.kind == kind) out.push_back(e);
    return out;
  }
  int inserts = 0;
  int updates = 0;

 private:
  void collect() {
    std::vector<EventDeriver::Change> changes;
    deriver_.take(changes);
    for (const EventDeriver::Change& c : changes) {
      if (c.fresh) {
        EXPECT_EQ(rows_.count(c.id), 0u) << "id " << c.id << " inserted twice";
        ++inserts;
      } else {
        EXPECT_EQ(rows_.count(c.id), 1u) << "update of id " << c.id << " before its insert";
        ++updates;
      }
      rows_[c.id] = c.event;
    }
  }
  EventDeriver deriver_;
  std::map<int64_t, RecordedEvent> rows_;
};

ServoSample at(std::size_t i) {
  ServoSample s;
  s.t = static_cast<double>(i) * kPeriod;
  return s;
}

TEST(EventDeriver, StateChangesAndPenetrationWithItsDeepestPoint) {
  Events events;
  // free 0-9, sliding 10-19, inserting 20-39 (depth to 0.95 mm), extracting 40-49, sliding 50-59.
  for (std::size_t i = 0; i < 60; ++i) {
    ServoSample s = at(i);
    if (i >= 10) s.state = InteractionState::Sliding;
    if (i >= 20 && i < 40) {
      s.state = InteractionState::Inserting;
      s.depth = 0.05f * static_cast<float>(i - 20);
      s.lesion = 2;
    }
    if (i >= 40 && i < 50) {
      s.state = InteractionState::Extracting;
      s.depth = 0.95f - 0.09f * static_cast<float>(i - 40);
      s.lesion = 2;
    }
    events.add(s);
  }
  events.finish();
  const auto states = events.of("state");
  ASSERT_EQ(states.size(), 4u);
  EXPECT_EQ(states[0].detail, "free->sliding");
  EXPECT_DOUBLE_EQ(states[0].t, 0.010);
  EXPECT_EQ(states[1].detail, "sliding->inserting");
  EXPECT_EQ(states[1].lesion, 2);
  EXPECT_EQ(states[2].detail, "inserting->extracting");
  EXPECT_NEAR(states[2].value, 0.95, 1e-6) << "depth at extraction";
  EXPECT_EQ(states[3].detail, "extracting->sliding");

  const auto penetration = events.of("penetration");
  ASSERT_EQ(penetration.size(), 1u);
  EXPECT_DOUBLE_EQ(penetration[0].t, 0.020);
  EXPECT_EQ(penetration[0].lesion, 2);
  EXPECT_NEAR(penetration[0].value, 0.95, 1e-6);
  EXPECT_NEAR(penetration[0].duration, 0.029, 1e-12);
}

TEST(EventDeriver, SoftTissuePressesAreEpisodesWithTheirPeak) {
  Events events(1.0);
  // Two presses: peak 3 N, then a force hovering around the threshold (one press, not many), then a
  // touch below the threshold (no event).
  const auto force_at = [](std::size_t i) -> float {
    if (i >= 10 && i < 30) return 3.0f - 0.1f * static_cast<float>(i > 20 ? i - 20 : 20 - i);
    if (i >= 50 && i < 70) return (i % 2 == 0) ? 1.2f : 0.8f;
    if (i >= 90 && i < 95) return 0.9f;
    return 0.0f;
  };
  for (std::size_t i = 0; i < 110; ++i) {
    ServoSample s = at(i);
    s.soft_tissue_force = force_at(i);
    events.add(s);
  }
  events.finish();
  const auto presses = events.of("soft_tissue");
  ASSERT_EQ(presses.size(), 2u);
  EXPECT_EQ(presses[0].detail, "peak_force");
  EXPECT_NEAR(presses[0].value, 3.0, 1e-6);
  EXPECT_DOUBLE_EQ(presses[0].t, 0.010);  // the first sample above 1 N (2 N)
  EXPECT_NEAR(presses[1].value, 1.2, 1e-6);
  EXPECT_DOUBLE_EQ(presses[1].t, 0.050);
  EXPECT_NEAR(presses[1].duration, 0.019, 1e-12);
}

TEST(EventDeriver, OverrunsCloseTogetherAreOneEpisode) {
  Events events;
  // Overruns at 100, 101, 150 (within 100 ms: one episode of 3), then at 400 (a second one).
  for (std::size_t i = 0; i < 600; ++i) {
    ServoSample s = at(i);
    s.overrun = i == 100 || i == 101 || i == 150 || i == 400;
    events.add(s);
  }
  events.finish();
  const auto overruns = events.of("overrun");
  ASSERT_EQ(overruns.size(), 2u);
  EXPECT_EQ(overruns[0].value, 3.0);
  EXPECT_DOUBLE_EQ(overruns[0].t, 0.100);
  EXPECT_NEAR(overruns[0].duration, 0.050, 1e-12);
  EXPECT_EQ(overruns[1].value, 1.0);
  EXPECT_GT(events.updates, 0) << "a growing episode is updated in place";
}

TEST(EventDeriver, SafetyAndEngineFlagRuns) {
  Events events;
  for (std::size_t i = 0; i < 300; ++i) {
    ServoSample s = at(i);
    if (i >= 10 && i < 60) s.safety_flags = kSafetyStale;
    if (i >= 200 && i < 205) s.step_flags = kFlagInfeasible | kFlagJumpLimited;
    events.add(s);
  }
  events.finish();
  const auto safety = events.of("safety");
  ASSERT_EQ(safety.size(), 1u);
  EXPECT_EQ(safety[0].detail, "stale_input");
  EXPECT_EQ(safety[0].value, 50.0);
  const auto engine = events.of("engine");
  ASSERT_EQ(engine.size(), 2u);
  EXPECT_EQ(engine[0].detail, "jump_limited");
  EXPECT_EQ(engine[1].detail, "infeasible");
  EXPECT_EQ(engine[1].value, 5.0);
}

// The clamp episodes come from the step's flags (the one clamp, its output stage), not from
// safety_flags, which say only what force safety did.
TEST(EventDeriver, ClampEpisodesComeFromTheStepsFlags) {
  Events events;
  for (std::size_t i = 0; i < 300; ++i) {
    ServoSample s = at(i);
    if (i >= 20 && i < 50) s.step_flags = kFlagForceClamped;
    if (i >= 100 && i < 110) s.step_flags = kFlagTorqueClamped;
    if (i >= 150 && i < 160) s.safety_flags = 0x3u;  // bits no longer set: no episode
    events.add(s);
  }
  events.finish();
  const auto safety = events.of("safety");
  ASSERT_EQ(safety.size(), 2u);
  EXPECT_EQ(safety[0].detail, "force_clamped");
  EXPECT_EQ(safety[0].value, 30.0);
  EXPECT_EQ(safety[1].detail, "torque_clamped");
  EXPECT_EQ(safety[1].value, 10.0);
  EXPECT_TRUE(events.of("engine").empty());
}

TEST(EventDeriver, ButtonEdgesAndGaps) {
  Events events;
  std::size_t index = 0;
  for (std::size_t i = 0; i < 30; ++i) {
    index = i < 20 ? i : i + 9;  // samples 20..28 missing
    ServoSample s = at(index);
    s.buttons = (i >= 5 && i < 10) ? 0b10u : 0u;
    events.add(s);
  }
  events.finish();
  const auto buttons = events.of("button");
  ASSERT_EQ(buttons.size(), 2u);
  EXPECT_EQ(buttons[0].detail, "pressed");
  EXPECT_EQ(buttons[0].value, 1.0);
  EXPECT_DOUBLE_EQ(buttons[0].t, 0.005);
  EXPECT_EQ(buttons[1].detail, "released");
  const auto gaps = events.of("gap");
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].detail, "missing_samples");
  EXPECT_EQ(gaps[0].value, 9.0);
  EXPECT_DOUBLE_EQ(gaps[0].t, 0.019);
}

TEST(EventDeriver, QuietStreamHasNoEvents) {
  Events events;
  for (std::size_t i = 0; i < 1000; ++i) events.add(at(i));
  events.finish();
  EXPECT_EQ(events.inserts, 0);
}

}  // namespace
}  // namespace cariesim::record
