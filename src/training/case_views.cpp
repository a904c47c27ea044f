// The report's case pictures (docs/reports.md, "The gradebook"): each recorded diagnosis case seen from
// above, drawn from the model. The trial is rebuilt from its study and its recorded seed
// (make_trial, docs/training.md "Seeds"); the teeth are the scene's tooth meshes projected on the
// world's xy plane (the scene's up is +z, as the tool's home above the arch), each as its convex
// outline; the lesions are placed and snapped on their tooth as the model builder places them, and
// the rebuilt case must name the recorded case's sites and severities, else its lesions are not drawn.
#include <fmt/format.h>

#include <algorithm>
#include <boost/geometry.hpp>
#include <boost/geometry/geometries/multi_point.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <climits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/geometry/ray_cast.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/training/report.hpp"
#include "cariesim/training/study.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace {

namespace bg = boost::geometry;
using Point2 = bg::model::d2::point_xy<double>;

// A tooth of a study's scene in the world: its mesh (for snapping lesions) and its outline from above.
struct Tooth {
  TriangleMesh world;
  std::vector<Point2> outline;  // convex, closed (the first point repeated last)
};

// The teeth of one scene, by object index (objects that are not teeth are absent).
using Teeth = std::map<int, Tooth>;

// A tooth object's surface in the world; null for a shape that is not a tooth's.
std::unique_ptr<TriangleMesh> tooth_mesh(const ObjectDesc& o) {
  std::unique_ptr<TriangleMesh> mesh;
  if (o.shape.kind == ShapeDesc::Kind::Mesh)
    mesh = std::make_unique<TriangleMesh>(load_mesh(o.shape.file, nullptr, mesh_load_options(o.shape)));
  else if (o.shape.kind == ShapeDesc::Kind::Molar)
    mesh = std::make_unique<TriangleMesh>(make_molar(o.shape.molar));
  else if (o.shape.kind == ShapeDesc::Kind::Premolar)
    mesh = std::make_unique<TriangleMesh>(make_premolar(o.shape.premolar));
  if (mesh) mesh->transform(o.pose);
  return mesh;
}

// Every tooth (an object with an FDI number) of `scene`, with its outline from above.
Teeth scene_teeth(const SceneDesc& scene) {
  Teeth teeth;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const ObjectDesc& o = scene.objects[i];
    if (o.fdi == 0) continue;
    std::unique_ptr<TriangleMesh> mesh = tooth_mesh(o);
    if (!mesh || mesh->vertices.empty()) continue;
    bg::model::multi_point<Point2> points;
    points.reserve(mesh->vertices.size());
    for (const Vec3f& v : mesh->vertices) points.emplace_back(v.x(), v.y());
    bg::model::polygon<Point2> hull;
    bg::convex_hull(points, hull);
    Tooth t;
    t.world = std::move(*mesh);
    t.outline.assign(hull.outer().begin(), hull.outer().end());
    teeth.emplace(static_cast<int>(i), std::move(t));
  }
  return teeth;
}

// Most cases drawn: each is rebuilt (a scene parsed, its lesions snapped) and drawn as a panel, so a
// database of many thousand crafted trials does not make the report run for hours or the page huge.
constexpr std::size_t kMaxDrawnCases = 500;

// What is known of one study: the study, its scene's teeth, or why there is no picture.
struct StudyViews {
  std::optional<Study> study;
  Teeth teeth;
  std::string problem;
};

}  // namespace

std::size_t add_case_views(Report& report, const std::vector<std::string>& study_files) {
  ReportTable outlines{"case_outlines",
                       "Case pictures: the teeth",
                       "Per study, each tooth's outline seen from above (world x, y in mm), from the scene's "
                       "meshes; the case pictures draw them.",
                       {},
                       {}};
  outlines.columns = {{"study", "Study", 0},
                      {"tooth", "Tooth", 0},
                      {"point", "Point", 0},
                      {"x_mm", "x (mm)", 3},
                      {"y_mm", "y (mm)", 3}};
  ReportTable points{"case_points",
                     "Case pictures: lesions and marks",
                     "Per trainee and case, each lesion (where the model places it, its severity, found or "
                     "missed) and each mark (its grade; found, again or false) seen from above (world x, y "
                     "in mm).",
                     {},
                     {}};
  points.columns = {
      {"participant", "Trainee", 0}, {"study", "Study", 0},       {"case", "Case", 0},
      {"what", "What", 0},           {"number", "Number", 0},     {"x_mm", "x (mm)", 3},
      {"y_mm", "y (mm)", 3},         {"size_mm", "Size (mm)", 2}, {"grade", "Severity or grade", 0},
      {"result", "Result", 0}};
  outlines.in_html = points.in_html = false;
  outlines.section = points.section = "";  // data for the figures: not on the page

  // The studies the trials name: a course's study files first, then the built-ins by name.
  std::map<std::string, StudyViews> studies;
  std::map<std::string, Study> from_files;
  for (const std::string& file : study_files) {
    Study s = load_study(file);
    from_files.emplace(s.name, std::move(s));
  }
  const std::vector<std::string> builtins = builtin_study_names();
  auto views_of = [&](const std::string& name) -> StudyViews& {
    auto it = studies.find(name);
    if (it != studies.end()) return it->second;
    StudyViews v;
    try {
      if (const auto f = from_files.find(name); f != from_files.end())
        v.study = f->second;
      else if (std::find(builtins.begin(), builtins.end(), name) != builtins.end())
        v.study = load_study(name);
      else
        v.problem = "no built-in study of that name (give its course with --course)";
      if (v.study) {
        // The teeth do not depend on the case: the first trial's scene gives them.
        const SceneDesc scene = make_trial(*v.study, 0, 0).scene();
        v.teeth = scene_teeth(scene);
        for (const auto& [index, tooth] : v.teeth)
          for (std::size_t k = 0; k < tooth.outline.size(); ++k)
            outlines.rows.push_back(
                {Cell::of_text(name), Cell::of_text(scene.objects[static_cast<std::size_t>(index)].name),
                 Cell::of_integer(static_cast<std::int64_t>(k)), Cell::of_number(tooth.outline[k].x()),
                 Cell::of_number(tooth.outline[k].y())});
      }
    } catch (const Error& e) {
      v.study.reset();
      v.problem = e.what();
    }
    return studies.emplace(name, std::move(v)).first->second;
  };

  std::size_t drawn = 0;
  std::vector<std::string> unplaced;
  std::map<std::string, std::int64_t> case_index;  // per trainee, as the cases table numbers them
  for (const StudyTrial& t : report.merged.finished) {
    if (t.kind != kKindDiagnosis) continue;
    const std::int64_t index = ++case_index[t.participant];
    if (!t.diagnosis_case) continue;
    if (drawn == kMaxDrawnCases) {
      report.warnings.push_back(fmt::format("only the first {} cases are drawn", kMaxDrawnCases));
      break;
    }
    const RecordedCase& c = *t.diagnosis_case;
    StudyViews& views = views_of(t.study);
    auto cell = [](const std::string& s) { return Cell::of_text(s); };

    // The lesions where the model places them, when the rebuilt case is the recorded one.
    std::vector<std::optional<LesionShape>> placed(c.lesions.size());
    std::string why;
    if (!views.study) {
      why = views.problem;
    } else if (t.trial > INT_MAX || t.seed < 0) {
      why = "its trial number or seed cannot be rebuilt";
    } else {
      try {
        const TrialSetup setup =
            make_trial(*views.study, static_cast<int>(t.trial - 1), static_cast<std::uint64_t>(t.seed));
        bool same = setup.truth.lesions.size() == c.lesions.size();
        for (std::size_t k = 0; same && k < c.lesions.size(); ++k)
          same = setup.truth.lesions[k].site == c.lesions[k].site &&
                 grade_name(setup.truth.lesions[k].severity) == c.lesions[k].severity;
        if (!same) {
          why = "the case rebuilt from its seed is not the recorded one (another version of the study?)";
        } else {
          const SceneDesc scene = setup.scene();
          for (std::size_t k = 0; k < c.lesions.size() && k < scene.lesions.size(); ++k) {
            const LesionDesc& l = scene.lesions[k];
            LesionShape s = lesion_shape_in_world(scene, l);
            const auto tooth = views.teeth.find(l.object);
            if (l.snap && tooth != views.teeth.end())
              if (const auto along = nearest_crossing(tooth->second.world, s.center, s.normal, l.snap_range))
                s.center += *along * s.normal;
            placed[k] = s;
          }
        }
      } catch (const Error& e) {
        why = e.what();
      }
    }
    if (!why.empty())
      unplaced.push_back(
          fmt::format("{} case {} ({} trial {}): {}", t.participant, index, t.study, t.trial, why));

    // The rows: each lesion (when placed), then each mark.
    for (std::size_t k = 0; k < c.lesions.size(); ++k) {
      if (!placed[k]) continue;
      const bool found = std::any_of(c.marks.begin(), c.marks.end(), [&](const RecordedMark& m) {
        return m.first && m.lesion == static_cast<int>(k + 1);
      });
      points.rows.push_back({cell(t.participant), cell(t.study), Cell::of_integer(index), cell("lesion"),
                             Cell::of_integer(static_cast<std::int64_t>(k + 1)),
                             Cell::of_number(placed[k]->center.x()), Cell::of_number(placed[k]->center.y()),
                             Cell::of_number(placed[k]->size), cell(c.lesions[k].severity),
                             cell(found ? "found" : "missed")});
    }
    for (std::size_t i = 0; i < c.marks.size(); ++i) {
      const RecordedMark& m = c.marks[i];
      points.rows.push_back({cell(t.participant), cell(t.study), Cell::of_integer(index), cell("mark"),
                             Cell::of_integer(static_cast<std::int64_t>(i + 1)), Cell::of_number(m.tip[0]),
                             Cell::of_number(m.tip[1]), Cell{}, cell(m.grade),
                             cell(m.lesion == 0 ? "false"
                                  : m.first     ? "found"
                                                : "again")});
    }
    ++drawn;
  }
  if (!unplaced.empty())
    report.warnings.push_back(fmt::format("{} case picture(s) without their lesions: {}{}", unplaced.size(),
                                          unplaced.front(), unplaced.size() > 1 ? "; ..." : ""));
  report.tables.push_back(std::move(outlines));
  report.tables.push_back(std::move(points));
  return drawn;
}

}  // namespace cariesim::training
