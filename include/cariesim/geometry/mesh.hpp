#pragma once
/// Triangle meshes: import (STL ASCII/binary, OBJ, PLY through assimp), validation and repair.
/// Coordinates are millimetres.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "cariesim/common/hash.hpp"
#include "cariesim/common/math.hpp"

namespace cariesim {

/// An indexed triangle mesh; triangles wind counter-clockwise seen from outside (outward normals).
struct TriangleMesh {
  std::vector<Vec3f> vertices;                     ///< mm
  std::vector<std::array<uint32_t, 3>> triangles;  ///< indices into vertices

  /// Axis-aligned bounds (mm); both zero for an empty mesh.
  [[nodiscard]] Eigen::AlignedBox3d bounds() const;
  /// Applies a rigid transform to every vertex.
  void transform(const Pose& pose);
  /// Enclosed volume (mm^3), positive for outward-facing triangles of a closed mesh.
  [[nodiscard]] double volume() const;
  /// Surface area (mm^2).
  [[nodiscard]] double area() const;
};

/// What validation found and what it repaired.
struct MeshReport {
  std::size_t input_triangles = 0;     ///< triangles before repair
  std::size_t degenerate_removed = 0;  ///< zero-area triangles dropped
  std::size_t duplicates_merged = 0;   ///< coincident vertices welded
  std::size_t boundary_edges = 0;      ///< edges with one triangle (open mesh) after repair
  std::size_t nonmanifold_edges = 0;   ///< edges with more than two triangles after repair
  bool flipped = false;                ///< the winding was reversed to face outward
  std::size_t reoriented = 0;          ///< triangles turned to agree with their neighbours' winding
  std::size_t holes_filled = 0;        ///< small boundary loops closed (MeshLoadOptions::fill_small_holes)
  std::size_t components = 0;          ///< connected shells after repair
  std::size_t self_intersections = 0;  ///< intersecting pairs of non-adjacent triangles (when checked)
  std::vector<std::string> warnings;   ///< human-readable notes on the repairs
  [[nodiscard]] bool watertight() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
};

/// Bytes: mesh files larger than this are refused before reading (a tooth scan is a few MB).
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{1} << 30;

/// Import options.
/// mm: the smallest and largest extent a mesh may have (after `scale`); outside, it is an error
/// naming the units (a scan in micrometres or metres read as millimetres).
inline constexpr double kMinMeshExtent = 0.1;
inline constexpr double kMaxMeshExtent = 1000.0;

struct MeshLoadOptions {
  double scale = 1.0;            ///< multiplies coordinates (files are expected in mm); load_mesh only
  bool require_closed = true;    ///< reject open / non-manifold meshes that cannot be repaired
  bool fill_small_holes = true;  ///< close boundary loops of at most kMaxFilledHoleEdges edges
  bool check_self_intersections = true;  ///< count intersecting triangle pairs: an error when
                                         ///< require_closed, else a warning
};
/// A key hashes every field of MeshLoadOptions (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<MeshLoadOptions> = 4;

/// Longest boundary loop (edges) that validation closes when fill_small_holes is set.
inline constexpr std::size_t kMaxFilledHoleEdges = 8;

/// Loads STL (ASCII or binary), OBJ or PLY through assimp, validates and repairs it (welds vertices,
/// drops degenerate triangles, orients outward). Throws cariesim::Error naming the file and the
/// problem: missing, empty, truncated, non-finite coordinates, degenerate, open or non-manifold.
TriangleMesh load_mesh(const std::filesystem::path& file, MeshReport* report = nullptr,
                       const MeshLoadOptions& options = {});

/// Validates and repairs an in-memory mesh the same way; `what` names it in messages.
void validate_mesh(TriangleMesh& mesh, const std::string& what, MeshReport* report = nullptr,
                   const MeshLoadOptions& options = {});

/// Writes a binary STL (used by tests and by `cariesim tree` exports).
void save_stl(const TriangleMesh& mesh, const std::filesystem::path& file);

}  // namespace cariesim
