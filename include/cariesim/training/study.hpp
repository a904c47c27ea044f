#pragma once
/// Study files (docs/training.md): YAML descriptions of the paper's three studies —
/// `tuning` (Tables 1-2), `boundary-shapes` (§4.2.2, Fig. 13) and `diagnosis` (§5.3, Figs. 15-17) —
/// parsed as strictly as scenes: an unknown key or a bad value is a cariesim::Error naming
/// "file:line:column" and the field. Built-in studies are embedded like the built-in scenes.
///
///   const Study study = load_study("boundary-shapes");   // or a path to a YAML file
///   const TrialSetup setup = make_trial(study, 0, trial_seed(study_seed, 0));
///   SceneDesc scene = setup.scene();                     // what to build and load for that trial
///
/// Every random choice of a trial comes from that trial's seed (docs/training.md gives the draw order),
/// so make_trial(study, i, seed) gives the same trial on any machine.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/spheretree/lesion.hpp"

namespace cariesim::training {

/// What kind of study (trials.kind in the study database: kKind* of study_schema.hpp).
enum class StudyKind : uint8_t { Tuning, Boundary, Diagnosis };
/// "tuning", "boundary-shapes", "diagnosis".
std::string_view study_kind_name(StudyKind kind);

/// What the tuning study's sliders change (paper Tables 1 and 2).
enum class TuningTarget : uint8_t {
  Roughness,  ///< μs and μd (Table 1), on a friction block
  Insertion,  ///< k_c and k_e (N/mm, Table 2), on an insertion block
};

/// A lesion grade as the participant names it (and as lesions are authored).
enum class Grade : uint8_t { Mild, Severe };
/// "mild", "severe".
std::string_view grade_name(Grade grade);
/// Parses "mild"/"severe"; false otherwise.
bool parse_grade(std::string_view text, Grade& out);

/// One slider the participant tunes.
struct TunedParameter {
  std::string name;    ///< "mu_s", "mu_d", "k_c" or "k_e" (the kScore* names of study_schema.hpp)
  std::string unit;    ///< "" for μs/μd, "N/mm" for k_c/k_e
  double min = 0.0;    ///< slider minimum, in unit
  double max = 1.0;    ///< slider maximum, in unit
  double start = 0.5;  ///< where the slider starts in this trial (drawn from the trial's seed), in unit
};

/// Settings of a tuning study (`tuning:` in the study file).
struct TuningDesc {
  TuningTarget target = TuningTarget::Roughness;
  std::string scene;   ///< built-in scene name or file; default friction-block / insertion-blocks
  std::string lesion;  ///< the lesion of that scene the sliders change; default its first
  /// Slider ranges (start unused here: drawn per trial uniformly in [min, max]).
  std::vector<TunedParameter> parameters;
  std::vector<Grade> levels{Grade::Mild, Grade::Severe};  ///< shown in an order drawn per trial
};

/// Settings of a boundary-shapes study (`boundary:` in the study file); defaults are the paper's.
struct BoundaryDesc {
  Vec3 cube{100.0, 100.0, 20.0};  ///< mm, each cube's edges (top face at z = 0)
  double spacing = 120.0;         ///< mm, between the cubes' centres along x
  double shape_size = 60.0;       ///< mm, square side, triangle side, circle diameter
  double depth = 2.0;             ///< mm, how deep the hidden region reaches
  double mu_s = 0.5;              ///< static friction of the hidden region
  double mu_d = 0.3;              ///< dynamic friction of the hidden region
  double stiffness = 1.0;         ///< N/mm, both regions
  std::vector<std::string> shapes{"square", "triangle", "circle"};  ///< one per cube, order drawn
};

/// The kinds of diagnosis site (`diagnosis.sites[].site`), in the order the study file names them:
/// "occlusal", "occlusal-fossa", "occlusal-fissure", "buccal-pit", "lingual-pit", "interproximal",
/// "mesial", "distal" ("occlusal" and "interproximal" when the file does not say which).
std::vector<std::string> site_kind_names();

/// Where a diagnosis lesion may be placed (`diagnosis.sites` in the study file): a region of a tooth's
/// surface, an ellipse in the tangent plane at `at` (half-axes `region`, mm, along the tangent and
/// across it). A drawn lesion's centre lies anywhere in it (drawn from the trial's seed), then is
/// snapped onto the tooth along the normal, as a scene's lesion is (docs/training.md).
struct LesionSite {
  std::string name;              ///< unique within the study, e.g. "46-occlusal-fossa"
  SourceLoc where;               ///< the entry in the study file
  std::string object;            ///< the tooth object of the scene, e.g. "tooth46"
  int fdi = 0;                   ///< that object's FDI number (from the scene)
  std::string site;              ///< its kind: one of site_kind_names()
  Vec3 at = Vec3::Zero();        ///< mm, the region's centre in the object frame (snapped onto the surface)
  Vec3 normal = Vec3::UnitZ();   ///< outward normal there (object frame)
  Vec3 tangent = Vec3::UnitX();  ///< in-plane direction of the shape (object frame)
  /// mm, the region's half-axes along the tangent (projected into the tangent plane) and across it;
  /// {0, 0}: the point `at` only
  std::array<double, 2> region{0.0, 0.0};
  double snap_range = 3.0;  ///< mm
  /// The shapes a lesion here may take (drawn among them; a listed case may name any); the first is
  /// the default. Disk, stripe, ellipsoid, inverted-cone.
  std::vector<LesionShape::Kind> shapes{LesionShape::Kind::Disk};
  Vec3 world_at = Vec3::Zero();  ///< mm, `at` in the world (the object's pose), for keeping lesions apart
};

/// One hidden lesion of a diagnosis case.
struct CaseLesion {
  std::string site;  ///< a LesionSite name
  Grade severity = Grade::Mild;
  double size = 2.0;   ///< mm (LesionShape::size)
  double width = 1.0;  ///< mm (LesionShape::width: stripes and ellipsoids)
  double depth = 1.2;  ///< mm below the surface
  LesionShape::Kind shape = LesionShape::Kind::Disk;  ///< the lesion's shape
  /// mm, where its centre lies in the site's region: along the site's tangent and across it (within
  /// the region's ellipse), before it is snapped onto the tooth
  std::array<double, 2> offset{0.0, 0.0};
};

/// The site's tangent in its tangent plane (unit), and the direction across it (normal × that): the
/// axes of its region and of a lesion's offset.
std::array<Vec3, 2> site_axes(const LesionSite& site);
/// The point of `site`'s region at `offset` (mm along site_axes), in the object frame: where a lesion
/// with that offset is placed before it is snapped onto the tooth.
Vec3 site_point(const LesionSite& site, const std::array<double, 2>& offset);
/// True when `offset` lies in `site`'s region (its ellipse; a point region takes only {0, 0}).
bool in_site_region(const LesionSite& site, const std::array<double, 2>& offset);

/// How cases are drawn when the study file gives no case list (`diagnosis.generate`).
struct CaseGenerator {
  int min_count = 1;  ///< lesions per case, drawn in [min_count, max_count]
  int max_count = 3;
  double mild_fraction = 0.5;  ///< probability that a lesion is mild
  double min_size = 1.5;       ///< mm, size drawn uniformly in [min_size, max_size]
  double max_size = 3.0;
  double min_width = 0.8;  ///< mm, width (stripes, ellipsoids)
  double max_width = 1.4;
  double mild_depth[2] = {0.6, 1.2};    ///< mm, depth range of a mild lesion (enamel)
  double severe_depth[2] = {1.5, 2.5};  ///< mm, depth range of a severe lesion (into dentin)
};

/// Settings of a diagnosis study (`diagnosis:` in the study file).
struct DiagnosisDesc {
  std::string scene = "real-arch";  ///< built-in scene name or file; its own lesions are removed
  std::vector<LesionSite> sites;
  /// The case list: trial i is case i while i < cases.size(); after it, trials draw their case
  /// from their seed when `generate` is set, else the list starts over (case i % size).
  std::vector<std::vector<CaseLesion>> cases;
  std::optional<CaseGenerator> generate;  ///< how cases beyond the list are drawn
  double time_limit = 180.0;              ///< s per case (servo time); 0: none
  double detection_margin = 0.5;          ///< mm beyond the lesion's footprint a mark still counts
};

/// Thresholds of the safety scores (`scoring:` in the study file).
struct ScoringDesc {
  /// N, soft-tissue force above this counts as damage; unset: the recording's soft_tissue_threshold
  std::optional<double> soft_tissue_threshold;
  double enamel_force_limit = 4.0;     ///< N, force on hard tissue above this is excess
  double blocked_min_duration = 0.05;  ///< s, a press on caries at F_p* this long without entering is blocked
};

/// When a trainee sees the debrief of a diagnosis case (`debrief:` in the study file,
/// docs/training.md): its lesions beside the marks, the scores in words and the replay.
enum class DebriefWhen : uint8_t {
  AfterEachCase,  ///< "after-each-case": when each case ends, before the next begins
  AtEnd,          ///< "at-end": every case's debrief once the last case has ended
  Never,          ///< "never" (the default; an exam): no debrief in the window
};

/// A parsed, validated study file.
struct Study {
  /// The file's `name` (else its stem): a valid_identifier (course.hpp), as it names the trials'
  /// recording files
  std::string name;
  std::string description;   ///< free text
  std::string origin;        ///< file path or "builtin:NAME"
  std::string source;        ///< the YAML text as read (stored with each trial, docs/training.md)
  uint64_t source_hash = 0;  ///< hash of the YAML text
  StudyKind kind = StudyKind::Tuning;
  int trials = 1;                ///< trials per participant
  std::optional<uint64_t> seed;  ///< the study seed, < 2^63; unset: drawn when a run starts
  TuningDesc tuning;
  BoundaryDesc boundary;
  DiagnosisDesc diagnosis;
  ScoringDesc scoring;
  DebriefWhen debrief = DebriefWhen::Never;  ///< when the window shows a case's debrief
};

/// Parses study YAML. `origin` names the text in messages and anchors relative scene paths. Throws
/// cariesim::Error "file:line:column: message" on any problem (unknown key, wrong type, missing
/// field, out-of-range value, an unknown site or scene object).
Study parse_study(std::string_view yaml, const std::filesystem::path& origin);
/// A built-in study name ("tuning", "boundary-shapes", "diagnosis", ...) or a path to a YAML file.
Study load_study(const std::string& name_or_file);
/// Names of the built-in studies.
std::vector<std::string> builtin_study_names();
/// The YAML text of a built-in study; empty when there is none of that name.
std::string_view builtin_study_yaml(std::string_view name);

/// Largest study seed: seeds are stored in SQLite's signed INTEGER (trials.seed), so [0, 2^63 - 1].
inline constexpr uint64_t kMaxSeed = (uint64_t{1} << 63) - 1;

/// A seed written as text (a study file's `seed:`, `--seed` of `cariesim run` and `cariesim study run`):
/// decimal digits only (no sign, no spaces, no hex), a value in [0, kMaxSeed]. Unset for anything
/// else, so "-1" or "99999999999999999999" can never wrap around to 2^64 - 1.
std::optional<uint64_t> parse_seed(std::string_view text);

/// The seed of trial `index` of a run whose study seed is `study_seed`: the (index+1)-th output of a
/// std::mt19937_64 seeded with study_seed, shifted right by one (63 bits: it fits SQLite's INTEGER).
uint64_t trial_seed(uint64_t study_seed, int index);

/// The study seed of one participant: the first output of a std::mt19937_64 seeded through
/// std::seed_seq with the study seed's low and high 32 bits, the participant ID's length and its
/// bytes, shifted right by one (docs/training.md, "seeds"). A run's trial seeds are trial_seed of it,
/// so two participants of one study seed get different cases, each rebuilt from its trials.seed.
uint64_t participant_seed(uint64_t study_seed, std::string_view participant);

/// What is hidden in a trial: the scorer's truth, never shown to a trainee.
struct TrialTruth {
  std::vector<std::string> shapes;  ///< boundary: the hidden shape of each cube, in cube order
  std::vector<CaseLesion> lesions;  ///< diagnosis: the case's lesions (scene lesions "lesionN", N from 1)
};

/// One trial as the participant gets it.
struct TrialSetup {
  int index = 0;  ///< 0-based trial number within the run
  StudyKind kind = StudyKind::Tuning;
  uint64_t seed = 0;         ///< this trial's seed (recorded in trials.seed)
  std::string scene_yaml;    ///< the scene to build and load (parse_scene(scene_yaml, scene_origin))
  std::string scene_origin;  ///< names the scene in messages and anchors its relative paths
  /// Tuning: the levels to tune, in the order asked, and the sliders (start drawn per trial).
  std::vector<Grade> levels;
  std::vector<TunedParameter> parameters;
  std::string tuned_lesion;  ///< the scene lesion the sliders change
  /// Boundary: the cube objects of the scene, in the order the participant names their shapes, and
  /// the shape names offered as answers.
  std::vector<std::string> cubes;
  std::vector<std::string> shape_choices;
  double time_limit = 0.0;  ///< s of servo time for a diagnosis case; 0: none
  TrialTruth truth;         ///< what is hidden (for the scorer and tests; never show it to a trainee)

  /// The scene, parsed (throws cariesim::Error like parse_scene).
  [[nodiscard]] SceneDesc scene() const;
};

/// Trial `index` of `study` made from `seed` (the draws of docs/training.md). Throws cariesim::Error
/// when the trial cannot be made (e.g. a case site missing from the scene).
TrialSetup make_trial(const Study& study, int index, uint64_t seed);

}  // namespace cariesim::training
