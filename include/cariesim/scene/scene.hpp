#pragma once
/// Scenes: YAML files (yaml-cpp) and built-in scenes (DESIGN.md §6), and building a Model from them.
/// The format is documented in docs/scene-format.md.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/progress.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {

/// Parses scene YAML. `origin` names the text in messages and anchors relative mesh paths.
/// Throws cariesim::Error with "file:line:column: message" on any problem (wrong type, missing
/// field, unknown key, out-of-range value).
SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin);

/// A built-in scene name ("oral-cavity", "friction-block", ...) or a path to a YAML file.
SceneDesc load_scene(const std::string& name_or_file);

/// Names of the built-in scenes, the default ("oral-cavity") first.
std::vector<std::string> builtin_scene_names();
/// The YAML text of a built-in scene; empty when there is none of that name.
std::string_view builtin_scene_yaml(std::string_view name);

/// The folder of the data the program ships (data/ in the repository: the real tooth scans under
/// open-full-jaw/): $CARIESIM_DATA_DIR when set and not empty, else the folder the build recorded.
/// A scene's mesh file named "data:PATH" is PATH in this folder (the built-in real-arch scene's
/// teeth). It is not checked here: a missing file is reported where it is used.
std::filesystem::path data_directory();

/// A one-object scene around a mesh file (`cariesim tree MESH`): identity pose, rigid generic
/// tissue, no lesions. Throws cariesim::Error when the file does not exist.
SceneDesc mesh_scene(const std::filesystem::path& mesh, const TreeDesc& tree = {});

struct BuildOptions {
  bool use_cache = true;                   ///< read and write the tree cache
  /// Write to the tree cache the parts of objects that carry lesions (their healthy and caries parts
  /// hold the lesions' geometry). False in trainee mode: a drawn case's lesions are never left in the
  /// station's cache (they are read from it when there, and built otherwise).
  bool cache_lesion_parts = true;
  std::filesystem::path cache_dir;         ///< empty: TreeCache::default_dir()
  std::optional<TreeMode> mode;            ///< overrides every object's tree mode
  std::optional<int> octree_depth;         ///< overrides the octree depth
  std::optional<double> tolerance;         ///< mm, overrides the tight tolerance
  bool measure_deviation = false;          ///< measure every part's surface deviation (slow)
  std::size_t deviation_samples = 100000;  ///< surface samples per part when measuring
  ProgressFn progress;                     ///< long builds report here
};

/// mm: the seam band reaches this far each side of a lesion's border along the surface (issue #10).
inline constexpr double kSeamBandHalfWidth = 0.5;

/// What building one collision part took (`cariesim tree`, benchmarks).
struct PartReport {
  std::string name;  ///< e.g. "tooth46/healthy", "tooth46/lesion1"
  int object = -1;   ///< index into Model::objects
  std::size_t leaves = 0;
  int levels = 0;                            ///< tree levels (a lone root has 1)
  std::vector<std::size_t> nodes_per_level;  ///< level 0 = root
  double build_seconds = 0.0;  ///< s, level sets, tree, labels and display mesh, or the cache load
  bool cache_hit = false;
  std::optional<Deviation> deviation;  ///< mm, when BuildOptions::measure_deviation
  /// mm, a caries part when BuildOptions::measure_deviation: the union of all of its object's parts
  /// against the object's uncut surface within kSeamBandHalfWidth of this lesion's border.
  std::optional<Deviation> seam_deviation;
};

/// What building a whole model took.
struct BuildReport {
  std::vector<PartReport> parts;  ///< one per Model::objects entry, same order
  double total_seconds = 0.0;     ///< s, the whole build_model call
};

/// The tree cache's key of one part of a scene object (`part` -1: the healthy or whole part, k: the
/// caries of its k-th lesion) as build_model uses it: every field of the object's shape (a mesh file
/// by content), pose and tree settings (`params`: after BuildOptions' overrides; the object's voxel),
/// and of the world shapes of its lesions (snapped), in order. Reads a mesh shape's file.
uint64_t part_cache_key(const ObjectDesc& object, const TreeParams& params,
                        const std::vector<LesionShape>& lesions, int part);

/// Builds the engine's Model: meshes or procedural shapes, level sets, CSG with the lesions
/// (healthy = tooth - lesion, caries = tooth ∩ lesion), sphere trees (cached), materials, the tool.
/// Throws cariesim::Error naming the scene entry (file:line:column) when a part cannot be built, a
/// lesion misses its tooth, or the tool's home pose collides. `report`, when given, is filled.
Model build_model(const SceneDesc& scene, const BuildOptions& options = {}, BuildReport* report = nullptr);

/// A lesion's caries material to write back into its scene (the viewer's "save to scene file").
struct LesionMaterialEdit {
  std::string lesion;  ///< the lesion's name in the scene
  Material material;   ///< k_e, stiffness, mu_s, mu_d, k_c, f_p_star, f_e_star, k_theta are written
};

/// The scene text `yaml` with the `material` mapping of each edited lesion set: k_e, stiffness,
/// mu_s, mu_d, k_c (its profile), f_p_star, f_e_star, k_theta; an `anisotropic` entry is kept as
/// written unless the material became isotropic (aniso_dir zero), which removes it. Comments and
/// layout are not kept (yaml-cpp re-emits the document). The result is parsed again before it is
/// returned. Throws cariesim::Error naming `origin` when the text is not valid YAML, a lesion is
/// missing, or the result is not a valid scene.
std::string set_lesion_materials(std::string_view yaml, const std::filesystem::path& origin,
                                 const std::vector<LesionMaterialEdit>& edits);

/// Writes the scene `source` (a built-in scene name or a YAML file) with the edits to `target`.
/// When `target` already exists it is first copied to `target` + ".bak", which is returned (else an
/// empty path). Throws cariesim::Error naming the file on any problem (then `target` is unchanged).
std::filesystem::path save_lesion_materials(const std::string& source, const std::filesystem::path& target,
                                            const std::vector<LesionMaterialEdit>& edits);

}  // namespace cariesim
