// The diagnosis study's lesion sites (docs/training.md, "diagnosis"): regions on every posterior tooth of
// the real arch, each on its tooth's surface; drawn lesions anywhere in their regions, every tooth and
// every kind of site coming up; each participant's own cases, or an exam's shared ones.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/ray_cast.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/training/course.hpp"
#include "cariesim/training/run.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;

// The real arch's teeth, each surface in the world as the scene builder snaps onto it, loaded once.
class Arch {
 public:
  Arch() : scene_(load_scene("real-arch")) {}
  const SceneDesc& scene() const { return scene_; }
  const ObjectDesc& object(const std::string& name) const {
    return scene_.objects[static_cast<std::size_t>(scene_.find_object(name))];
  }
  const TriangleMesh& mesh(const std::string& name) {
    auto it = meshes_.find(name);
    if (it == meshes_.end()) {
      const ObjectDesc& o = object(name);
      TriangleMesh m = load_mesh(o.shape.file, nullptr, mesh_load_options(o.shape));
      m.transform(o.pose);
      it = meshes_.emplace(name, std::move(m)).first;
    }
    return it->second;
  }
  // Where a lesion placed at `at` (object frame) along `normal` lands on the tooth (world), as
  // build_model snaps it; none when the line misses the tooth within the range.
  std::optional<Vec3> snap(const LesionSite& site, const Vec3& at) {
    const Pose& pose = object(site.object).pose;
    const Vec3 p = pose.transform(at);
    const Vec3 n = pose.q * site.normal;
    const std::optional<double> t = nearest_crossing(mesh(site.object), p, n, site.snap_range);
    if (!t) return std::nullopt;
    return p + *t * n;
  }

 private:
  SceneDesc scene_;
  std::map<std::string, TriangleMesh> meshes_;
};

Arch& arch() {
  static Arch a;
  return a;
}

const LesionSite& site_named(const Study& s, const std::string& name) {
  for (const LesionSite& site : s.diagnosis.sites)
    if (site.name == name) return site;
  throw Error("no site " + name);
}

const std::set<int> kPosterior{34, 35, 36, 37, 44, 45, 46, 47};
const std::set<std::string> kKinds{"occlusal-fossa", "occlusal-fissure", "buccal-pit",
                                   "lingual-pit",    "mesial",           "distal"};

// Every posterior tooth has its sites (molars: fossa, fissure, buccal and lingual pits, mesial and
// distal surfaces; premolars the same without the pits), each a region, not a point.
TEST(DiagnosisSites, EveryPosteriorToothHasItsRegions) {
  for (const std::string name : {"diagnosis", "diagnosis-paper"}) {
    SCOPED_TRACE(name);
    const Study s = load_study(name);
    std::map<int, std::set<std::string>> kinds;
    for (const LesionSite& site : s.diagnosis.sites) {
      kinds[site.fdi].insert(site.site);
      EXPECT_GT(site.region[0], 0.0) << site.name;
      EXPECT_GT(site.region[1], 0.0) << site.name;
    }
    std::set<int> teeth;
    for (const auto& [fdi, k] : kinds) {
      teeth.insert(fdi);
      const bool molar = fdi % 10 >= 6;
      std::set<std::string> want = kKinds;
      if (!molar) want.erase("buccal-pit"), want.erase("lingual-pit");
      EXPECT_EQ(k, want) << "tooth " << fdi;
    }
    EXPECT_EQ(teeth, kPosterior);
  }
}

// The regions are on the teeth: the centre and eight points of each region's rim snap onto the tooth
// along the site's normal within its snap range, as the scene builder snaps a lesion
// (scripts/studies/diagnosis_sites.py makes them so; this checks the study file it wrote).
TEST(DiagnosisSites, EveryRegionSnapsOntoItsTooth) {
  const Study s = load_study("diagnosis");
  for (const LesionSite& site : s.diagnosis.sites) {
    SCOPED_TRACE(site.name);
    for (int k = -1; k < 8; ++k) {
      const double a = k < 0 ? 0.0 : k * 0.25 * std::numbers::pi;
      const double r = k < 0 ? 0.0 : 1.0;
      const std::array<double, 2> offset{r * std::cos(a) * site.region[0], r * std::sin(a) * site.region[1]};
      EXPECT_TRUE(arch().snap(site, site_point(site, offset)).has_value()) << "rim point " << k;
    }
  }
}

// Over many seeds, every posterior tooth, every kind of site, every shape and both grades come up;
// each drawn lesion lies in its site's region, is placed there in the trial's scene, and snaps onto its
// tooth; two lesions of a case are apart.
TEST(DiagnosisSites, DrawnLesionsCoverEveryToothAndKindAndLieInTheirRegions) {
  const Study s = load_study("diagnosis");
  ASSERT_TRUE(s.diagnosis.cases.empty());  // every case drawn
  std::set<int> teeth;
  std::set<std::string> kinds;
  std::set<LesionShape::Kind> shapes;
  std::set<Grade> grades;
  std::set<std::string> sites;
  for (int i = 0; i < 300; ++i) {
    const TrialSetup t = make_trial(s, i % 3, trial_seed(20261126, i));
    const SceneDesc scene = t.scene();
    ASSERT_EQ(scene.lesions.size(), t.truth.lesions.size());
    ASSERT_GE(t.truth.lesions.size(), 1u);
    for (std::size_t k = 0; k < t.truth.lesions.size(); ++k) {
      const CaseLesion& c = t.truth.lesions[k];
      const LesionSite& site = site_named(s, c.site);
      SCOPED_TRACE(c.site);
      teeth.insert(site.fdi);
      kinds.insert(site.site);
      shapes.insert(c.shape);
      grades.insert(c.severity);
      sites.insert(c.site);
      EXPECT_TRUE(in_site_region(site, c.offset));
      EXPECT_NE(std::find(site.shapes.begin(), site.shapes.end(), c.shape), site.shapes.end());
      // The scene's lesion: on the site's tooth, at the drawn point of the region, of the drawn shape.
      const LesionDesc& l = scene.lesions[k];
      EXPECT_EQ(scene.objects[static_cast<std::size_t>(l.object)].name, site.object);
      EXPECT_LT((l.shape.center - site_point(site, c.offset)).norm(), 1e-9);
      EXPECT_EQ(l.shape.kind, c.shape);
      EXPECT_TRUE(arch().snap(site, l.shape.center).has_value());
      for (std::size_t j = 0; j < k; ++j)
        EXPECT_GT((site.world_at - site_named(s, t.truth.lesions[j].site).world_at).norm(), 2.0);
    }
  }
  EXPECT_EQ(teeth, kPosterior);
  EXPECT_EQ(kinds, kKinds);
  EXPECT_EQ(shapes,
            (std::set<LesionShape::Kind>{LesionShape::Kind::Disk, LesionShape::Kind::Stripe,
                                         LesionShape::Kind::Ellipsoid, LesionShape::Kind::InvertedCone}));
  EXPECT_EQ(grades, (std::set<Grade>{Grade::Mild, Grade::Severe}));
  EXPECT_GT(sites.size(), s.diagnosis.sites.size() * 3 / 4);
}

// A drawn case builds: its lesions' teeth (the rest of the arch is cached and lesion-free) with
// coarser trees, each lesion snapped where the test's own snap puts it, in its site's region.
TEST(DiagnosisSites, ADrawnCaseBuildsWithItsLesionsInTheirRegions) {
  const Study s = load_study("diagnosis");
  const TrialSetup t = make_trial(s, 0, trial_seed(7, 2));
  SceneDesc scene = t.scene();
  // Only the teeth that carry a lesion (lesion objects renumbered).
  SceneDesc hosts = scene;
  hosts.objects.clear();
  std::map<int, int> index;
  for (LesionDesc& l : hosts.lesions) {
    if (!index.count(l.object)) {
      index[l.object] = static_cast<int>(hosts.objects.size());
      hosts.objects.push_back(scene.objects[static_cast<std::size_t>(l.object)]);
    }
    l.object = index[l.object];
  }
  BuildOptions options;
  options.tolerance = 0.1;
  const Model model = build_model(hosts, options);
  ASSERT_EQ(model.lesions.size(), t.truth.lesions.size());
  for (std::size_t k = 0; k < model.lesions.size(); ++k) {
    const LesionSite& site = site_named(s, t.truth.lesions[k].site);
    SCOPED_TRACE(site.name);
    const std::optional<Vec3> snapped = arch().snap(site, site_point(site, t.truth.lesions[k].offset));
    ASSERT_TRUE(snapped.has_value());
    EXPECT_LT((model.lesions[k].shape.center - *snapped).norm(), 1e-9);
    // In the region: the snapped centre's offset from the region's centre, across the normal.
    const Pose& pose = arch().object(site.object).pose;
    const std::array<Vec3, 2> axes = site_axes(site);
    const Vec3 d = model.lesions[k].shape.center - pose.transform(site.at);
    EXPECT_TRUE(in_site_region(site, {d.dot(pose.q * axes[0]), d.dot(pose.q * axes[1])}));
  }
}

// A site's region, shapes and a listed lesion's shape and offset are checked and located.
TEST(DiagnosisSites, BadRegionsShapesAndOffsetsAreLocated) {
  const std::string head =
      "kind: diagnosis\ndiagnosis:\n  scene: oral-cavity\n  sites:\n    - {name: a, object: tooth46, site: ";
  struct Case {
    std::string yaml;
    std::string where;  // "line:column"
    std::string what;   // part of the message
  };
  const std::vector<Case> cases = {
      {head + "occlusal-fossa, at: [0, 0, 7], normal: [0, 0, 1], region: [1, 1, 1]}\n  generate: {}\n",
       "5:98", "sites[0].region: expected [along, across]"},
      {head + "occlusal-fossa, at: [0, 0, 7], normal: [0, 0, 1], region: [1, -0.5]}\n  generate: {}\n",
       "5:102", "sites[0].region[1]"},
      {head + "occlusal-fossa, at: [0, 0, 7], normal: [0, 0, 1], region: [1, 25]}\n  generate: {}\n", "5:102",
       "sites[0].region[1]"},
      {head + "fissure, at: [0, 0, 7], normal: [0, 0, 1]}\n  generate: {}\n", "5:40", "site"},
      {head + "mesial, at: [0, 0, 7], normal: [0, 0, 1], shape: disk, shapes: [disk]}\n  generate: {}\n",
       "5:103", "give `shape` or `shapes`, not both"},
      {head + "mesial, at: [0, 0, 7], normal: [0, 0, 1], shapes: [disk, cube]}\n  generate: {}\n", "5:97",
       "shapes[1]"},
      {head + "mesial, at: [0, 0, 7], normal: [0, 0, 1], shapes: [disk, disk]}\n  generate: {}\n", "5:97",
       "shape 'disk' listed twice"},
      {head + "mesial, at: [0, 0, 7], normal: [0, 0, 1], shapes: []}\n  generate: {}\n", "5:90",
       "expected one to four shapes"},
      {head +
           "mesial, at: [0, 0, 7], normal: [0, 0, 1], region: [1, 0.5]}\n  cases:\n    - lesions: [{site: a, "
           "severity: mild, offset: [0.8, 0.4]}]\n",
       "7:51", "[0.8, 0.4] lies outside the region of site 'a' (half-axes [1, 0.5] mm)"},
      {head +
           "mesial, at: [0, 0, 7], normal: [0, 0, 1]}\n  cases:\n    - lesions: [{site: a, severity: mild, "
           "offset: [0.1, 0]}]\n",
       "7:51", "lies outside the region"},
      {head +
           "mesial, at: [0, 0, 7], normal: [0, 0, 1]}\n  cases:\n    - lesions: [{site: a, severity: mild, "
           "shape: blob}]\n",
       "7:50", "shape"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.yaml);
    std::string msg;
    try {
      (void)parse_study(c.yaml, "test.yaml");
    } catch (const Error& e) {
      msg = e.what();
    }
    EXPECT_NE(msg.find("test.yaml:" + c.where + ":"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.what), std::string::npos) << msg;
  }
  // A good one: the listed lesion's shape and offset as given.
  const Study s =
      parse_study(head +
                      "mesial, at: [0, 0, 7], normal: [0, 0, 1], region: [1, 0.5], shapes: [ellipsoid, "
                      "disk]}\n  cases:\n    - lesions: [{site: a, severity: mild, offset: [0.6, "
                      "-0.3], shape: stripe}]\n",
                  "test.yaml");
  ASSERT_EQ(s.diagnosis.cases.size(), 1u);
  EXPECT_EQ(s.diagnosis.sites[0].site, "mesial");
  EXPECT_EQ(s.diagnosis.cases[0][0].shape, LesionShape::Kind::Stripe);
  EXPECT_EQ(s.diagnosis.cases[0][0].offset, (std::array<double, 2>{0.6, -0.3}));
}

// The paper's study keeps the paper's case first: the real-arch scene's own three lesions, placed
// exactly as the scene places them.
TEST(DiagnosisSites, ThePaperStudysFirstCaseIsTheScenesOwnLesions) {
  const Study s = load_study("diagnosis-paper");
  const SceneDesc paper = arch().scene();
  const SceneDesc first = make_trial(s, 0, 1).scene();
  ASSERT_EQ(first.lesions.size(), 3u);
  ASSERT_EQ(paper.lesions.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const LesionDesc& a = first.lesions[k];
    const LesionDesc& b = paper.lesions[k];
    EXPECT_EQ(first.objects[static_cast<std::size_t>(a.object)].name,
              paper.objects[static_cast<std::size_t>(b.object)].name);
    EXPECT_EQ(a.shape.kind, b.shape.kind);
    EXPECT_EQ(a.shape.center, b.shape.center);
    EXPECT_EQ(a.shape.normal, b.shape.normal);
    if (a.shape.kind != LesionShape::Kind::Disk) {
      EXPECT_LT((a.shape.tangent - b.shape.tangent).norm(), 1e-12);  // normalized twice
    }
    EXPECT_EQ(a.shape.size, b.shape.size);
    EXPECT_EQ(a.shape.depth, b.shape.depth);
    EXPECT_EQ(a.severity, b.severity);
    EXPECT_EQ(a.snap_range, b.snap_range);
  }
  // Later trials are drawn.
  EXPECT_NE(make_trial(s, 1, 5).scene_yaml, make_trial(s, 1, 6).scene_yaml);
}

// The lesions of each trial of a run, as text: site, shape, place, size, depth, grade.
std::vector<std::string> cases_of(const Study& study, const fs::path& db, const std::string& participant,
                                  const Course* course, std::optional<uint64_t> seed) {
  RunOptions o;
  o.participant = participant;
  o.station = "s1";
  o.database = db;
  o.seed = seed;
  if (course != nullptr) apply_course_seed(*course, o);
  StudyRun run(study, o);
  std::vector<std::string> cases;
  while (!run.finished()) {
    const TrialSetup& t = run.begin_trial();
    std::string text;
    for (const CaseLesion& c : t.truth.lesions)
      text += c.site + " " + std::string(lesion_kind_name(c.shape)) + " " + std::to_string(c.offset[0]) +
              " " + std::to_string(c.offset[1]) + " " + std::to_string(c.size) + " " +
              std::to_string(c.depth) + " " + std::string(grade_name(c.severity)) + "; ";
    cases.push_back(text);
    run.abandon_trial();
  }
  return cases;
}

std::string course_yaml(const std::string& extra) {
  return "course: Diagnosis, group A\nstudy: diagnosis\nrecords: records\nstation: s1\n" + extra +
         "instructor: "
         "pbkdf2-sha256$600000$ba9f44571da1cd87db4514d1c8529d2c$"
         "507309be11afaf095e2d9b42fbb6b0639f9e4c686035c1eb08d477ec3a119722\n";
}

// Two trainees of one class (one course, even one fixed study seed) never share a case, the first
// included; the same trainee again gets the same cases.
TEST(ParticipantCases, TwoTraineesOfOneCourseGetDifferentCases) {
  const fs::path dir = test::scratch();
  const Course course = parse_course(course_yaml(""), dir / "course.yaml");
  EXPECT_FALSE(course.exam_seed.has_value());
  const Study study = load_study(course.study);
  for (const std::optional<uint64_t> seed : {std::optional<uint64_t>(), std::optional<uint64_t>(99)}) {
    const std::vector<std::string> a = cases_of(study, dir / "class.db", "P01", &course, seed);
    const std::vector<std::string> b = cases_of(study, dir / "class.db", "P02", &course, seed);
    ASSERT_EQ(a.size(), 3u);
    ASSERT_EQ(b.size(), 3u);
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NE(a[i], b[i]) << "trial " << i + 1;
    if (seed) {
      EXPECT_EQ(cases_of(study, dir / "class.db", "P01", &course, seed), a);
    }
  }
}

// A course's exam seed gives every trainee the same cases: those of the seed itself.
TEST(ParticipantCases, AnExamSeedGivesEveryTraineeTheSameCases) {
  const fs::path dir = test::scratch();
  const Course course = parse_course(course_yaml("exam_seed: 20261126\n"), dir / "course.yaml");
  ASSERT_EQ(course.exam_seed, std::optional<uint64_t>(20261126));
  const Study study = load_study(course.study);
  const std::vector<std::string> a = cases_of(study, dir / "exam.db", "P01", &course, std::nullopt);
  const std::vector<std::string> b = cases_of(study, dir / "exam.db", "P02", &course, std::nullopt);
  EXPECT_EQ(a, b);
  const auto seeds = test::query(dir / "exam.db", "SELECT participant, trial, seed FROM trials ORDER BY id");
  ASSERT_EQ(seeds.size(), 6u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(seeds[i][2], std::to_string(trial_seed(20261126, static_cast<int>(i))));
    EXPECT_EQ(seeds[3 + i][2], seeds[i][2]);
  }
  // Different trials of the exam still differ.
  EXPECT_NE(a[0], a[1]);
}

// `exam_seed` is read as strictly as a study's seed, the error located.
TEST(ParticipantCases, ABadExamSeedIsLocated) {
  const fs::path dir = test::scratch();
  for (const std::string bad : {"-1", "0x10", "99999999999999999999", "1.5", "[1]", "''"}) {
    SCOPED_TRACE(bad);
    try {
      (void)parse_course(course_yaml("exam_seed: " + bad + "\n"), dir / "course.yaml");
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("course.yaml:5:12: exam_seed"), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace cariesim::training
