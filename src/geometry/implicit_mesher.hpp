#pragma once
/// Meshing of implicit solids for the procedural shapes (private to the geometry module).

#include <functional>
#include <string>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// An implicit solid: negative inside, positive outside, roughly a signed distance in mm.
using ImplicitFn = std::function<double(const Vec3&)>;

/// Samples `f` on a grid of `voxel_mm` voxels over `box` (mm; f must be positive on and outside its
/// faces) and extracts the zero set with OpenVDB's volumeToMesh. `lipschitz` bounds |grad f| and lets
/// whole 8^3 blocks far from the surface be skipped. The result is validated as a closed, outward
/// mesh named `what`; a failure (a bug in the shape) throws cariesim::Error.
TriangleMesh mesh_implicit(const ImplicitFn& f, const Eigen::AlignedBox3d& box, double voxel_mm,
                           double lipschitz, const std::string& what);

}  // namespace cariesim
