#pragma once
/// Procedural shapes, so the default scene needs no files (docs/design.md §3). Every mesh is closed,
/// manifold and wound outward. Object frames: x mesio-distal, y bucco-lingual, z occlusal (up).

#include <cstdint>
#include <vector>

#include "cariesim/common/hash.hpp"
#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// A box with the given edge lengths (mm), centred on the origin in x and y, top face at z = 0.
TriangleMesh make_cuboid(const Vec3& size_mm);

/// A lower molar. Frame origin: centre of the crown at the cemento-enamel junction; the crown spans
/// z in [0, crown_height], the roots go down to -root_length. +x is mesial and +y buccal, as for a
/// lower right tooth (FDI 46, 47); `mirrored` puts buccal at -y for the left side (36, 37).
/// Cusps (5): mesiobuccal, distobuccal, distal, mesiolingual, distolingual (4: without the distal);
/// fissures run between them from the central fossa; marginal ridges close the mesial and distal ends.
/// Built as an implicit solid meshed with OpenVDB; deterministic.
struct MolarParams {
  double mesiodistal = 11.0;   ///< mm, crown length along x
  double buccolingual = 10.0;  ///< mm, crown width along y
  double crown_height = 7.5;   ///< mm
  double root_length = 13.0;   ///< mm
  int cusps = 5;               ///< 4 or 5
  int roots = 2;               ///< 2: mesial and distal; 1: one fused root
  double resolution = 0.15;    ///< mm, target edge length of the surface mesh
  bool mirrored = false;       ///< buccal at -y (lower left teeth)
};
/// A key hashes every field of MolarParams (common/hash.hpp: a new field must be counted here).
template <>
inline constexpr std::size_t kKeyFields<MolarParams> = 8;
/// Throws cariesim::Error on parameters out of range (cusps not 4 or 5, non-positive sizes, ...).
TriangleMesh make_molar(const MolarParams& params = {});

/// A lower premolar (two cusps, the buccal one higher; one root), same frame conventions.
struct PremolarParams {
  double mesiodistal = 7.0;   ///< mm
  double buccolingual = 8.0;  ///< mm
  double crown_height = 8.0;  ///< mm
  double root_length = 14.0;  ///< mm
  double resolution = 0.15;   ///< mm
  bool mirrored = false;      ///< buccal at -y (lower left teeth)
};
/// A key hashes every field of PremolarParams (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<PremolarParams> = 6;
/// Throws cariesim::Error on parameters out of range.
TriangleMesh make_premolar(const PremolarParams& params = {});

/// Named points of a procedural tooth (mm, tooth frame), for placing lesions and neighbours.
struct ToothLandmarks {
  std::vector<Vec3> cusp_tips;  ///< mm, on the surface, in the order the tooth's comment lists them
  Vec3 central_fossa;           ///< mm, lowest point of the occlusal surface between the cusps
  Vec3 mesial_contact;          ///< mm, most mesial point of the crown (contact with the neighbour)
  Vec3 distal_contact;          ///< mm, most distal point of the crown
};
/// Landmarks of make_molar(params), found on the same implicit surface.
ToothLandmarks molar_landmarks(const MolarParams& params = {});
/// Landmarks of make_premolar(params): cusp tips buccal then lingual.
ToothLandmarks premolar_landmarks(const PremolarParams& params = {});

/// The gingiva around a row of teeth: a band following a polyline (mm, world xy) at the cervical level.
struct GingivaParams {
  std::vector<Vec3> path;   ///< mm, centre line of the arch segment at the gingival margin
  double width = 14.0;      ///< mm, bucco-lingual width of the band
  double height = 4.0;      ///< mm, thickness below the margin
  double resolution = 0.5;  ///< mm
};
/// A key hashes every field of GingivaParams (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<GingivaParams> = 4;
/// A rounded-rectangle cross-section (width x height) swept along the path, hanging below it, with
/// round ends; a single point gives a round pad. Throws cariesim::Error on an empty or non-finite path.
TriangleMesh make_gingiva_band(const GingivaParams& params);

/// A tongue: a flattened, rounded body (mm) centred on the origin, long axis along x.
struct TongueParams {
  double length = 50.0;     ///< mm
  double width = 45.0;      ///< mm
  double height = 15.0;     ///< mm
  double resolution = 1.0;  ///< mm
};
/// A key hashes every field of TongueParams (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<TongueParams> = 4;
/// A superellipsoid narrowing toward its tip at +x. Throws cariesim::Error on non-positive sizes.
TriangleMesh make_tongue(const TongueParams& params = {});

/// The dental explorer, in the tool frame: origin at the centre of the tip sphere, +z along the tip
/// segment toward the handle. Made of a handle, a tapered shank and a curved working end.
struct ExplorerParams {
  double tip_radius = 0.05;          ///< mm
  double tip_segment = 2.5;          ///< mm, straight part from the tip along +z
  double working_end_radius = 0.45;  ///< mm, wire radius where the working end meets the shank
  double bend_radius = 6.0;          ///< mm, radius of the curved working end
  double bend_angle = 1.75;          ///< rad, how far the working end curves
  double shank_length = 22.0;        ///< mm
  double shank_radius = 1.0;         ///< mm, at the handle end
  double handle_length = 90.0;       ///< mm
  double handle_radius = 4.5;        ///< mm
};
/// A key hashes every field of ExplorerParams (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<ExplorerParams> = 9;

/// One sphere of the tool's chain.
struct ToolSphere {
  Vec3 center;       ///< mm, tool frame
  double radius;     ///< mm
  uint16_t segment;  ///< 0 tip segment, 1 working end, 2 shank, 3 handle
};

/// The explorer as a chain of spheres along its centre line, ordered from the tip (sphere 0: centre at
/// the origin, radius tip_radius) to the handle, dense at the tip. Consecutive spheres overlap so that
/// their union dips at most `max_gap` mm below the ideal tube on the tip segment and working end,
/// 0.05 mm on the shank and 0.5 mm on the handle (173 spheres with the defaults; docs/tool-frame.md).
/// Throws cariesim::Error on invalid parameters.
std::vector<ToolSphere> make_explorer_spheres(const ExplorerParams& params = {}, double max_gap = 0.01);

/// A display mesh of the explorer: a closed tube along the same centre line with the same radius
/// profile, a hemisphere at the tip and a rounded handle end; tool frame.
TriangleMesh make_explorer_mesh(const ExplorerParams& params = {});

}  // namespace cariesim
