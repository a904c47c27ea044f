#pragma once
/// The model builder: a scene turned into the engine's Model (docs/scene-format.md, "What building
/// makes of it"): per object its mesh or procedural shape in the world, its lesions placed (and
/// snapped), level sets, the CSG parts (healthy = object - lesions, caries_i = object ∩ lesion_i; paper
/// §2.2), one sphere tree per part (from the tree cache or built), leaf labels and materials; then the
/// tool, gains, limits and the tool's home.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/common/progress.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/lesion.hpp"

namespace cariesim {

/// How build_model goes about it: the tree cache, overrides of every object's tree settings, surface
/// deviation measures, progress.
struct BuildOptions {
  bool use_cache = true;  ///< read and write the tree cache
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

/// mm: the seam band reaches this far each side of a lesion's border along the surface (the seam
/// deviation's band).
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

}  // namespace cariesim
