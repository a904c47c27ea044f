#pragma once
/// The parsed form of a scene file (docs/scene-format.md). parse_scene (scene.hpp) fills it and has
/// already checked every value (types, ranges, names, references); build_model turns it into a Model.
/// Geometry of objects and lesions is kept as authored: object shapes in the object frame, lesion
/// placements in the frame the file names; build_model maps them into the world.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/common/hash.hpp"
#include "cariesim/common/math.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/render/material.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/lesion.hpp"

namespace cariesim {

/// Where something was written: file, 1-based line and column (0 when unknown).
struct SourceLoc {
  std::string file;  ///< the scene's origin (a path, or "builtin:NAME")
  int line = 0;      ///< 1-based
  int column = 0;    ///< 1-based

  /// "file:line:column" (or just "file" when the position is unknown).
  [[nodiscard]] std::string str() const;
};

/// The geometry of a scene object, in its object frame (mm).
struct ShapeDesc {
  enum class Kind : uint8_t { Mesh, Cuboid, Molar, Premolar, Gingiva, Tongue };
  Kind kind = Kind::Cuboid;
  std::filesystem::path file;   ///< Mesh: resolved path (relative paths are taken from the scene file)
  double scale = 1.0;           ///< Mesh: multiplies the file's coordinates (files are in mm)
  Vec3 size{10.0, 10.0, 10.0};  ///< Cuboid: edge lengths (mm); top face at z = 0
  MolarParams molar;            ///< Molar
  PremolarParams premolar;      ///< Premolar
  GingivaParams gingiva;        ///< Gingiva (path in the object frame)
  TongueParams tongue;          ///< Tongue
};
/// ShapeDesc's fields (common/hash.hpp); its key is hash_fields below.
template <>
inline constexpr std::size_t kKeyFields<ShapeDesc> = 8;
/// Adds every field of a shape to a key (common/hash.hpp), a mesh file by its content instead of its
/// name, with the options it is loaded with (mesh_load_options). A field added to ShapeDesc does not
/// compile until it is hashed there.
void hash_fields(BuildKey& key, const ShapeDesc& shape);
/// How build_model loads a Mesh shape's file.
MeshLoadOptions mesh_load_options(const ShapeDesc& shape);

/// Name used in scene files ("mesh", "cuboid", "molar", "premolar", "gingiva", "tongue").
std::string_view shape_kind_name(ShapeDesc::Kind kind);

/// Sphere-tree settings of one object (TreeParams plus the level-set resolution).
struct TreeDesc {
  TreeParams params;            ///< mode, depth, tolerance, radii, leaf cap
  std::optional<double> voxel;  ///< mm, level-set voxel of the object and its lesions; unset: chosen
                                ///< from the tolerance (or octree depth) and the object's size
};
/// A key hashes both fields of a TreeDesc (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<TreeDesc> = 2;

/// One scene object: a tooth, a block, gingiva, the tongue.
struct ObjectDesc {
  std::string name;  ///< unique within the scene
  SourceLoc where;   ///< where the object's entry starts
  int fdi = 0;       ///< FDI tooth number (11..48), 0 when not a tooth
  ShapeDesc shape;   ///< geometry in the object frame
  Pose pose;         ///< object frame -> world (mm)
  ObjectKind kind = ObjectKind::Rigid;
  /// The healthy tissue's material: its tissue (enamel, dentin, gingiva, tongue or generic), contact
  /// stiffness and friction; the caries fields keep their defaults. The model's material as it is.
  Material material;
  /// mm; when set (tissue enamel), leaves deeper than this below the surface are labelled dentin
  std::optional<double> enamel_thickness;
  TreeDesc tree;
};

/// A lesion: an analytic volume placed on an object's surface, and its caries material.
struct LesionDesc {
  std::string name;          ///< unique within the scene
  SourceLoc where;           ///< where the lesion's entry starts
  int object = -1;           ///< index into SceneDesc::objects
  bool world_frame = false;  ///< placement (centre, normal, tangent, anisotropy) given in world frame
  bool snap = true;          ///< move the centre along the normal onto the object's surface
  double snap_range = 3.0;   ///< mm, how far snapping may move the centre
  /// Authored shape: kind, size, width, depth, polygon; centre/normal/tangent in the placement frame.
  LesionShape shape;
  std::string severity;  ///< "mild", "severe" or "" (no preset)
  /// Caries material (preset + overrides). aniso_dir is in the placement frame; lesion index unset.
  Material material;
};

/// One parameter override (`--set KEY=VALUE`, Python's Scene.with_overrides): the node at `key` in the
/// scene's YAML document is replaced by `value` before the document is read, so the result passes the
/// same checks as the file (docs/scene-format.md, "Overrides").
struct SceneOverride {
  std::string key;    ///< a path into the document: "lesions[0].material.k_c", "device.max_force"
  std::string value;  ///< YAML text of the new node: "0.4", "rigid", "{gradient: {top: 2, bottom: 6}}"

  friend bool operator==(const SceneOverride&, const SceneOverride&) = default;
};

/// A parsed, validated scene.
struct SceneDesc {
  std::string name;                      ///< scene name (the file's `name`, else its stem)
  std::string description;               ///< free text
  std::string origin;                    ///< the file path or "builtin:NAME"
  uint64_t source_hash = 0;              ///< hash of the YAML text (and of the overrides, when there are any)
  std::vector<SceneOverride> overrides;  ///< applied to the text before it was read, in order
  std::vector<ObjectDesc> objects;
  std::vector<LesionDesc> lesions;
  ExplorerParams tool;            ///< the dental explorer
  double tool_max_gap = 0.01;     ///< mm, largest gap of the tool's sphere chain along its surface
  std::optional<Pose> tool_home;  ///< tool frame -> world; unset: above the scene, pointing down
  DeviceLimits limits;
  CouplingGains gains;         ///< k_trans defaults to limits.max_stiffness
  double servo_rate = 1000.0;  ///< Hz

  /// Index of the object of that name, or -1.
  [[nodiscard]] int find_object(std::string_view object_name) const;
};

/// A lesion's shape in world coordinates as authored (placement frame mapped by the host's pose),
/// before snapping onto the surface.
LesionShape lesion_shape_in_world(const SceneDesc& scene, const LesionDesc& lesion);

}  // namespace cariesim
