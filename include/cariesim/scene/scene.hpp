#pragma once
/// Scenes: YAML files (yaml-cpp) and built-in scenes (docs/design.md §6); scene/model_builder.hpp builds a
/// Model from them. The format is documented in docs/scene-format.md.

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {

/// Parses scene YAML. `origin` names the text in messages and anchors relative mesh paths.
/// Throws cariesim::Error with "file:line:column: message" on any problem (wrong type, missing
/// field, unknown key, out-of-range value).
SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin);
/// Parses scene YAML after applying `overrides` in order to its document (missing mappings on the way are
/// created; a sequence index must exist): an overridden value is read by the same rules as the file (an
/// unknown key is refused, a value out of range named with its field), and a problem in it is located as
/// "origin (override KEY): field: message". The overrides are kept in SceneDesc::overrides and change
/// its source_hash.
SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin,
                      std::span<const SceneOverride> overrides);

/// A built-in scene name ("oral-cavity", "friction-block", ...) or a path to a YAML file.
SceneDesc load_scene(const std::string& name_or_file);
/// The same, with parameter overrides applied (parse_scene above).
SceneDesc load_scene(const std::string& name_or_file, std::span<const SceneOverride> overrides);

/// Reads one `--set` argument, "KEY=VALUE" (split at the first '='; spaces around KEY are dropped):
/// throws cariesim::Error "--set 'ARG': ..." when there is no '=' or KEY is not a path
/// (a name, then `.name` or `[index]` steps: "lesions[0].material.k_c").
SceneOverride parse_override(std::string_view assignment);

/// The scene text `yaml` with `overrides` placed in its document (for what is stored as text: a study
/// trial's scene). The overridden scene is checked first (parse_scene, whose located errors it
/// throws); comments and layout are not kept (yaml-cpp re-emits the document).
std::string override_scene_text(std::string_view yaml, const std::filesystem::path& origin,
                                std::span<const SceneOverride> overrides);

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
