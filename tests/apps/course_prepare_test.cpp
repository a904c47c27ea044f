// `cariesim course prepare COURSE` (docs/instructors.md): every case of a course's study built into the
// tree cache before class, so that a station's trial build loads each part instead of building it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "apps_support.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/study.hpp"
#include "support/files.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class CoursePrepare : public test::ScratchTest {
 protected:
  CoursePrepare() : ScratchTest("cariesim_course_prepare_") {}

  // A course on diagnosis-small (one molar) with two trials: the first the study's listed case, the
  // second drawn from its seed (`generate`); with `seed` the study's seed line stays.
  fs::path write_course(bool seed, const std::string& extra = "participants: [P01, P02]\n") {
    const fs::path examples = fs::path(CARIESIM_SOURCE_DIR) / "studies" / "examples";
    std::string study = test::read_text(examples / "diagnosis-small.yaml");
    std::vector<std::pair<std::string, std::string>> edits{
        {"scene: one-molar.yaml", "scene: '" + (examples / "one-molar.yaml").string() + "'"},
        {"trials: 1", "trials: 2"},
        {"scoring:",
         "  generate: {count: [1, 1], mild_fraction: 0.5, size: [1.6, 2.2], width: [0.8, 1.2], mild_depth: "
         "[0.6, 1.0], severe_depth: [1.3, 2.0]}\nscoring:"}};
    if (!seed) edits.emplace_back("seed: 7\n", "");
    for (const auto& [from, to] : edits) {
      const std::size_t at = study.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) study.replace(at, from.size(), to);
    }
    std::ofstream(dir_ / "study.yaml") << study;
    std::ofstream(dir_ / "course.yaml")
        << "course: Prepare test\nstudy: study.yaml\nrecords: records\n"
           "station: s1\n"
        << extra << "instructor: "
        << "pbkdf2-sha256$100000$ba9f44571da1cd87db4514d1c8529d2c$"
           "507309be11afaf095e2d9b42fbb6b0639f9e4c686035c1eb08d477ec3a119722\n";
    return dir_ / "course.yaml";
  }

  // Trial `index`'s scene as a trainee's station builds it (no lesion part written to the cache) from
  // `cache`, `stream` being the participant's stream (participant_seed, or an exam's seed): how many
  // of its parts came from the cache, of how many.
  std::pair<int, int> station_build(int index, uint64_t stream, const fs::path& cache) {
    const training::Study study = training::load_study((dir_ / "study.yaml").string());
    const training::TrialSetup setup = training::make_trial(study, index, training::trial_seed(stream, index));
    BuildOptions options;
    options.cache_dir = cache;
    options.cache_lesion_parts = false;
    BuildReport report;
    (void)build_model(setup.scene(), options, &report);
    int hits = 0;
    for (const PartReport& p : report.parts) hits += p.cache_hit ? 1 : 0;
    return {hits, static_cast<int>(report.parts.size())};
  }
};

// With the study's seed, both trials of each listed participant (the listed case and each one's drawn
// case) are built into the cache; a station's build of each then loads every part from it, lesion
// parts included. A station's build
// on a cache that was not prepared builds its lesion parts (they never go into the cache there).
TEST_F(CoursePrepare, EveryTrialOfASeededStudyHitsTheCache) {
  const fs::path course = write_course(true);
  const fs::path cache = dir_ / "cache";
  const test::CommandResult r = test::run_cariesim("course prepare '" + course.string() + "'",
                                                   "CARIESIM_CACHE_DIR='" + cache.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("trial 1 of 2: built into the tree cache"));
  EXPECT_THAT(r.out, HasSubstr("trial 2 of 2: built into the tree cache"));
  EXPECT_THAT(r.out, HasSubstr("prepared 3 scenes for 2 trials in " + cache.string()));  // one shared
  for (const char* p : {"P01", "P02"})
    for (int i = 0; i < 2; ++i) {
      const auto [hits, parts] = station_build(i, training::participant_seed(7, p), cache);
      EXPECT_GT(parts, 1) << p << " trial " << i + 1 << ": a tooth with a lesion has several parts";
      EXPECT_EQ(hits, parts) << p << " trial " << i + 1;
    }
  const auto [hits, parts] = station_build(1, training::participant_seed(7, "P01"), dir_ / "unprepared");
  EXPECT_LT(hits, parts) << "without prepare the lesion parts are built";
}

// Without a seed the drawn trial's case is not known before the run: prepare builds the listed case,
// says the drawn one is not prepared, and `--seed` (the stations' `cariesim run --seed`) prepares it.
TEST_F(CoursePrepare, DrawnTrialsNeedTheRunsSeed) {
  const fs::path course = write_course(false);
  const fs::path cache = dir_ / "cache";
  const std::string env = "CARIESIM_CACHE_DIR='" + cache.string() + "'";
  const test::CommandResult r = test::run_cariesim("course prepare '" + course.string() + "'", env);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("trial 1 of 2: built into the tree cache"));
  EXPECT_THAT(r.out, HasSubstr("trial 2 of 2: drawn from the run's seed, not prepared"));
  const auto [hits, parts] = station_build(0, 12345, cache);
  EXPECT_EQ(hits, parts) << "the listed case is the same for every seed";

  const test::CommandResult seeded =
      test::run_cariesim("course prepare '" + course.string() + "' --seed 12345", env);
  ASSERT_EQ(seeded.status, 0) << seeded.err;
  EXPECT_THAT(seeded.out, HasSubstr("trial 2 of 2: built into the tree cache"));
  const auto [hits2, parts2] = station_build(1, training::participant_seed(12345, "P02"), cache);
  EXPECT_EQ(hits2, parts2);

  const test::CommandResult bad =
      test::run_cariesim("course prepare '" + (dir_ / "none.yaml").string() + "'", env);
  EXPECT_NE(bad.status, 0);
  EXPECT_THAT(bad.err, HasSubstr("none.yaml"));
}

// An exam (the course's exam_seed) gives every participant the same cases: prepare builds them once,
// from that seed, with or without a list of participants.
TEST_F(CoursePrepare, AnExamSeedPreparesTheCasesEveryoneGets) {
  const fs::path course = write_course(false, "exam_seed: 99\n");
  const fs::path cache = dir_ / "cache";
  const test::CommandResult r = test::run_cariesim("course prepare '" + course.string() + "'",
                                                   "CARIESIM_CACHE_DIR='" + cache.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("prepared 2 scenes for 2 trials"));
  const auto [hits, parts] = station_build(1, 99, cache);
  EXPECT_EQ(hits, parts);
}

}  // namespace
}  // namespace cariesim
