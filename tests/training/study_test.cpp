// Study files (src/training/study.cpp) and trials made from seeds (src/training/trial.cpp).
#include "cariesim/training/study.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/fifo.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

// The message of the Error that parsing `yaml` throws ("" when it does not throw).
std::string parse_error(const std::string& yaml, const std::string& origin = "test.yaml") {
  try {
    (void)parse_study(yaml, origin);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(BuiltinStudies, AllParseAndMakeTheirFirstTrial) {
  const std::vector<std::string> names = builtin_study_names();
  EXPECT_EQ(names, (std::vector<std::string>{"tuning", "tuning-insertion", "boundary-shapes", "diagnosis",
                                             "diagnosis-paper"}));
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const Study s = load_study(name);
    EXPECT_EQ(s.name, name);
    EXPECT_EQ(s.origin, "builtin:" + name);
    const TrialSetup t = make_trial(s, 0, 12345);
    EXPECT_FALSE(t.scene().objects.empty());
  }
}

TEST(BuiltinStudies, ReproduceThePapersSettings) {
  // Tables 1-2: two levels, the target's two sliders; §4.2.2: ten trials of three 100 mm cubes with
  // 60 mm shapes, mu_s 0.5, mu_d 0.3, 1 N/mm; §5.3: diagnosis-paper's first case is the paper's three
  // lesions (diagnosis draws every case).
  const Study tuning = load_study("tuning");
  EXPECT_EQ(tuning.tuning.target, TuningTarget::Roughness);
  ASSERT_EQ(tuning.tuning.parameters.size(), 2u);
  EXPECT_EQ(tuning.tuning.parameters[0].name, "mu_s");
  EXPECT_EQ(tuning.tuning.parameters[1].name, "mu_d");
  EXPECT_EQ(load_study("tuning-insertion").tuning.parameters[0].name, "k_c");
  const Study boundary = load_study("boundary-shapes");
  EXPECT_EQ(boundary.trials, 10);
  EXPECT_EQ(boundary.boundary.cube, Vec3(100.0, 100.0, 20.0));
  EXPECT_EQ(boundary.boundary.shape_size, 60.0);
  EXPECT_EQ(boundary.boundary.mu_s, 0.5);
  EXPECT_EQ(boundary.boundary.mu_d, 0.3);
  EXPECT_EQ(boundary.boundary.stiffness, 1.0);
  EXPECT_TRUE(load_study("diagnosis").diagnosis.cases.empty());
  const Study diagnosis = load_study("diagnosis-paper");
  const TrialSetup first = make_trial(diagnosis, 0, 1);
  ASSERT_EQ(first.truth.lesions.size(), 3u);
  EXPECT_EQ(first.truth.lesions[2].severity, Grade::Mild);
  const SceneDesc scene = first.scene();
  ASSERT_EQ(scene.lesions.size(), 3u);
  EXPECT_EQ(scene.objects[static_cast<std::size_t>(scene.lesions[0].object)].fdi, 46);
  EXPECT_EQ(scene.objects[static_cast<std::size_t>(scene.lesions[2].object)].fdi, 36);
  EXPECT_EQ(scene.lesions[0].severity, "severe");
  EXPECT_EQ(first.time_limit, 180.0);
}

TEST(StudyParse, UnknownKeyIsLocated) {
  const std::string msg = parse_error("name: x\nkind: boundary-shapes\ntrails: 3\n", "dir/x.yaml");
  EXPECT_NE(msg.find("dir/x.yaml:3:1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("trails"), std::string::npos) << msg;
}

TEST(StudyParse, BadValuesAreLocatedAndNamed) {
  struct Case {
    std::string yaml;
    std::string where;  // "line:column"
    std::string what;   // a word of the message
  };
  const std::vector<Case> cases = {
      {"kind: boundary-shapes\ntrials: 0\n", "2:9", "trials"},
      {"kind: quiz\n", "1:7", "kind"},
      {"kind: boundary-shapes\nboundary:\n  shapes: [square, hexagon]\n", "3:20", "shapes[1]"},
      {"kind: boundary-shapes\nboundary:\n  shape_size: 120\n", "3:15", "does not fit"},
      {"kind: boundary-shapes\nseed: -4\n", "2:7", "seed"},
      {"kind: boundary-shapes\nseed: 99999999999999999999\n", "2:7", "seed: expected an integer in [0, "},
      {"kind: boundary-shapes\nseed: 9223372036854775808\n", "2:7", "seed: expected an integer in [0, "},
      {"kind: boundary-shapes\nseed: 0x10\n", "2:7", "seed"},
      // A name reaches the recordings' file names: the station-name rule (it escaped the folder).
      {"name: ../../../../tmp/x\nkind: boundary-shapes\n", "1:7",
       "name: '../../../../tmp/x' is not a valid study name"},
      {"name: /tmp/x\nkind: boundary-shapes\n", "1:7", "name: '/tmp/x' is not a valid study name"},
      {"name: ..\nkind: boundary-shapes\n", "1:7", "not a valid study name"},
      {"name: a b\nkind: boundary-shapes\n", "1:7", "not a valid study name"},
      {"name: ''\nkind: boundary-shapes\n", "1:7", "not a valid study name"},
      {"kind: boundary-shapes\ntuning:\n  target: roughness\n", "3:3", "no `tuning` section"},
      {"kind: tuning\ntuning:\n  target: roughness\n  parameters:\n    mu_s: [0.2, 7.0]\n", "5:17",
       "mu_s[1]"},
      {"kind: tuning\ntuning:\n  target: roughness\n  parameters:\n    k_c: [0.2, 1.0]\n", "5:10",
       "not tuned"},
      {"kind: tuning\ntuning:\n  target: insertion\n  lesion: nowhere\n", "3:3", "no lesion 'nowhere'"},
      {"kind: diagnosis\ndiagnosis:\n  scene: oral-cavity\n  sites:\n    - {name: a, object: tooth99, site: "
       "occlusal, at: [0, 0, 7], normal: [0, 0, 1]}\n  generate: {}\n",
       "5:25", "no object 'tooth99'"},
      {"kind: diagnosis\ndiagnosis:\n  scene: oral-cavity\n  sites:\n    - {name: a, object: tooth46, site: "
       "occlusal, at: [0, 0, 7], normal: [0, 0, 1]}\n  cases:\n    - lesions: [{site: b, severity: mild}]\n",
       "7:24", "unknown site 'b'"},
      {"kind: diagnosis\ndiagnosis:\n  scene: oral-cavity\n  sites:\n    - {name: a, object: tooth46, site: "
       "buccal, at: [0, 0, 7], normal: [0, 0, 1]}\n  generate: {}\n",
       "5:40", "site"},
      {"kind: diagnosis\ndiagnosis:\n  scene: oral-cavity\n  sites:\n    - {name: a, object: tooth46, site: "
       "occlusal, at: [0, 0, 7], normal: [0, 0, 1]}\n",
       "3:3", "give `cases`, `generate` or both"},
      {"kind: diagnosis\ndiagnosis:\n  scene: no-such-scene.yaml\n  sites: []\n", "3:10", "no-such-scene"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.yaml);
    const std::string msg = parse_error(c.yaml);
    EXPECT_NE(msg.find("test.yaml:" + c.where + ":"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.what), std::string::npos) << msg;
  }
}

// Without `name:` the file's stem names the study, under the same rule.
TEST(StudyParse, AFileNameThatIsNoValidStudyNameNeedsAName) {
  EXPECT_THAT(
      parse_error("kind: boundary-shapes\n", "dir/my study.yaml"),
      ::testing::HasSubstr("dir/my study.yaml: name: the file's name 'my study' is not a valid study name"));
  EXPECT_EQ(parse_error("name: mine\nkind: boundary-shapes\n", "dir/my study.yaml"), "");
  EXPECT_EQ(parse_study("kind: boundary-shapes\n", "dir/my-study.yaml").name, "my-study");
}

// One rule for every seed written as text (study files, --seed): digits in [0, 2^63 - 1]; "-1" and
// 20 digits used to wrap around to 2^64 - 1 on the command line.
TEST(StudySeeds, ParseSeedTakesDecimalDigitsInRangeOnly) {
  EXPECT_EQ(parse_seed("0"), std::optional<uint64_t>(0));
  EXPECT_EQ(parse_seed("42"), std::optional<uint64_t>(42));
  EXPECT_EQ(parse_seed("9223372036854775807"), std::optional<uint64_t>(kMaxSeed));
  for (const char* bad :
       {"", "-1", "+1", " 1", "1 ", "0x10", "1e3", "9223372036854775808", "18446744073709551615",
        "99999999999999999999", "123456789012345678901234567890", "4.2"})
    EXPECT_EQ(parse_seed(bad), std::nullopt) << bad;
}

TEST(StudyParse, AMissingFileNamesTheBuiltins) {
  try {
    (void)load_study("/nonexistent/study.yaml");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("boundary-shapes"), std::string::npos) << e.what();
  }
}

// Issue 26 item 15: a FIFO as a study file (`study check`, `study run`, a course's study) is refused
// naming its kind, without blocking; an oversized one (a sparse file here) by its size, unread.
TEST(StudyParse, AFifoOrAnOversizedFileIsRefused) {
  const auto dir = test::scratch();
  ASSERT_TRUE(cariesim::test::make_fifo(dir / "study.yaml"));
  const cariesim::test::FifoOutcome outcome = cariesim::test::read_fifo(
      dir / "study.yaml", [dir] { (void)load_study((dir / "study.yaml").string()); });
  EXPECT_FALSE(outcome.blocked) << "load_study blocked on a FIFO";
  EXPECT_NE(outcome.error.find("study: not a regular file (a FIFO (named pipe))"), std::string::npos)
      << outcome.error;
  const auto big = dir / "big.yaml";
  std::ofstream(big) << "kind: tuning\n";
  std::filesystem::resize_file(big, (std::uintmax_t{64} << 20) + 1);
  try {
    (void)load_study(big.string());
    FAIL() << "an oversized study loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("study: too large (67108865 bytes, at most 67108864)"),
              std::string::npos)
        << e.what();
  }
}

TEST(StudyParse, ExamplesParseWithTheirScenesRelativeToTheFile) {
  const Study s = load_study((test::examples() / "diagnosis-small.yaml").string());
  EXPECT_EQ(s.diagnosis.scene, (test::examples() / "one-molar.yaml").lexically_normal().string());
  EXPECT_EQ(s.seed, std::optional<uint64_t>(7));
  ASSERT_EQ(s.diagnosis.sites.size(), 2u);
  EXPECT_EQ(s.diagnosis.sites[1].site, "interproximal");
  EXPECT_EQ(s.diagnosis.sites[1].fdi, 46);
  EXPECT_EQ(s.scoring.soft_tissue_threshold, std::optional<double>(0.4));
}

TEST(StudySeeds, TrialSeedsAreTheStudyStreamsOutputs) {
  // std::mt19937_64's outputs are fixed by the standard: with seed 5489 the first is
  // 14514284786278117030 and the 10000th 9981545732273789042.
  EXPECT_EQ(trial_seed(5489, 0), 14514284786278117030ull >> 1);
  EXPECT_EQ(trial_seed(5489, 9999), 9981545732273789042ull >> 1);
  EXPECT_NE(trial_seed(5489, 1), trial_seed(5489, 0));
}

TEST(StudySeeds, TheSameSeedMakesTheSameTrial) {
  for (const std::string name : {"tuning", "boundary-shapes"}) {
    SCOPED_TRACE(name);
    const Study s = load_study(name);
    std::set<std::string> scenes;
    for (int i = 0; i < 12; ++i) {
      const TrialSetup a = make_trial(s, i, trial_seed(99, i));
      const TrialSetup b = make_trial(s, i, trial_seed(99, i));
      EXPECT_EQ(a.scene_yaml, b.scene_yaml);
      EXPECT_EQ(a.levels, b.levels);
      EXPECT_EQ(a.truth.shapes, b.truth.shapes);
      scenes.insert(a.scene_yaml);
    }
    // Different seeds draw different trials (slider starts, shape orders).
    EXPECT_GT(scenes.size(), 3u);
  }
}

TEST(StudySeeds, BoundaryOrdersAreDrawnAndBuiltAsDrawn) {
  const Study s = load_study("boundary-shapes");
  std::set<std::vector<std::string>> orders;
  for (int i = 0; i < 40; ++i) {
    const TrialSetup t = make_trial(s, i, trial_seed(2024, i));
    std::vector<std::string> sorted = t.truth.shapes;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, (std::vector<std::string>{"circle", "square", "triangle"}));
    orders.insert(t.truth.shapes);
    // Cube i hides shape i: a square is a 4-point polygon, a triangle a 3-point one, a circle a disk.
    const SceneDesc scene = t.scene();
    ASSERT_EQ(scene.lesions.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(scene.objects[static_cast<std::size_t>(scene.lesions[k].object)].name, t.cubes[k]);
      const LesionShape& shape = scene.lesions[k].shape;
      const std::string& hidden = t.truth.shapes[k];
      const std::size_t corners = hidden == "circle" ? 0u : hidden == "square" ? 4u : 3u;
      EXPECT_EQ(shape.kind, corners == 0 ? LesionShape::Kind::Disk : LesionShape::Kind::Polygon);
      EXPECT_EQ(shape.polygon.size(), corners);
      EXPECT_EQ(scene.lesions[k].material.mu_s, 0.5);
    }
  }
  EXPECT_EQ(orders.size(), 6u);  // every permutation comes up in 40 draws
}

TEST(StudySeeds, TuningStartsTheSlidersAtTheirDrawnValues) {
  const Study s = load_study("tuning");
  const TrialSetup t = make_trial(s, 0, 77);
  ASSERT_EQ(t.parameters.size(), 2u);
  ASSERT_EQ(t.levels.size(), 2u);
  EXPECT_NE(t.levels[0], t.levels[1]);
  const SceneDesc scene = t.scene();
  ASSERT_EQ(scene.lesions.size(), 1u);
  EXPECT_EQ(scene.lesions[0].name, t.tuned_lesion);
  EXPECT_DOUBLE_EQ(scene.lesions[0].material.mu_s, t.parameters[0].start);
  EXPECT_DOUBLE_EQ(scene.lesions[0].material.mu_d, t.parameters[1].start);
  for (const TunedParameter& p : t.parameters) {
    EXPECT_GE(p.start, p.min);
    EXPECT_LE(p.start, p.max);
  }
}

TEST(StudySeeds, GeneratedCasesFollowTheGenerator) {
  const Study s = load_study("diagnosis");
  ASSERT_TRUE(s.diagnosis.generate.has_value());
  const CaseGenerator& g = *s.diagnosis.generate;
  std::set<std::size_t> counts;
  for (int i = 1; i < 30; ++i) {
    const TrialSetup t = make_trial(s, i, trial_seed(5, i));
    EXPECT_EQ(make_trial(s, i, trial_seed(5, i)).scene_yaml, t.scene_yaml);
    counts.insert(t.truth.lesions.size());
    std::set<std::string> sites;
    for (const CaseLesion& l : t.truth.lesions) {
      sites.insert(l.site);
      const double* depth = l.severity == Grade::Mild ? g.mild_depth : g.severe_depth;
      EXPECT_GE(l.depth, depth[0]);
      EXPECT_LE(l.depth, depth[1]);
      EXPECT_GE(l.size, g.min_size);
      EXPECT_LE(l.size, g.max_size);
    }
    EXPECT_EQ(sites.size(), t.truth.lesions.size());  // no site twice
    EXPECT_EQ(t.scene().lesions.size(), t.truth.lesions.size());
  }
  EXPECT_EQ(counts, (std::set<std::size_t>{1, 2, 3}));
}

}  // namespace
}  // namespace cariesim::training
