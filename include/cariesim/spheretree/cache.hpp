#pragma once
/// On-disk cache of built trees and display meshes, keyed by a hash of inputs and parameters.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>

#include "cariesim/geometry/mesh.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// Incremental 64-bit hash (FNV-1a) of everything that determines a build.
class BuildKey {
 public:
  BuildKey& add(std::string_view bytes);
  BuildKey& add(const void* data, std::size_t size);
  BuildKey& add(double value);
  BuildKey& add(int64_t value);
  [[nodiscard]] uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 1469598103934665603ull;
};

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
  /// Returns the part when present and readable (a corrupt entry is ignored and removed).
  [[nodiscard]] std::optional<CachedPart> load(uint64_t key) const;
  /// Writes atomically (temporary file + rename); failures are reported as warnings, not errors.
  void store(uint64_t key, const CachedPart& part) const;
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

}  // namespace cariesim
