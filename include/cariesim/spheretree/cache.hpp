#pragma once
/// On-disk cache of built trees and display meshes, keyed by a hash of inputs and parameters.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>

#include "cariesim/common/hash.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// The one version of the tree cache: of its file layout and of everything that makes a cached part
/// without being a parameter of it (the tree builders, mesh import and repair, level sets, CSG, seam
/// leaves, display meshing). Bump it when any of them changes what a part holds; entries of another
/// version are never read (TreeCache names and checks entries with it). Keys (BuildKey) hold the
/// parameters: every field of every parameter struct (common/hash.hpp).
inline constexpr uint32_t kTreeCacheVersion = 9;

/// A cached build: a tree and the display mesh of the same part.
struct CachedPart {
  SphereTree tree;
  TriangleMesh display;
};

class TreeCache {
 public:
  /// `dir` defaults to $CARIESIM_CACHE_DIR, else $XDG_CACHE_HOME/cariesim, else ~/.cache/cariesim.
  explicit TreeCache(std::filesystem::path dir = default_dir());
  static std::filesystem::path default_dir();
  /// Returns the part stored under `key` by this kTreeCacheVersion when present and readable (a
  /// corrupt entry is ignored and removed).
  [[nodiscard]] std::optional<CachedPart> load(uint64_t key) const;
  /// Writes atomically (temporary file + rename); failures are reported as warnings, not errors.
  void store(uint64_t key, const CachedPart& part) const;
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

}  // namespace cariesim
