#pragma once
// Small hand-built models for the step's tests: a straight sphere-chain probe over slabs of spheres.
#include <functional>
#include <vector>

#include "cariesim/render/model.hpp"
#include "cariesim/spheretree/hierarchy.hpp"

namespace cariesim {
struct StateImpl;
}

namespace cariesim::test {

/// A straight probe along +z: tip sphere (0.05 mm) at the origin, a tapered 3 mm tip segment to
/// 0.5 mm, then a 1 mm shank up to z = 40 mm. Consecutive spheres overlap closely.
std::vector<ToolSphere> straight_probe();

/// A slab: spheres of `radius` on a square grid of `spacing`, tangent to the plane z = top from below.
struct SlabSpec {
  double x0 = -10.0, x1 = 10.0;  ///< mm
  double y0 = -10.0, y1 = 10.0;  ///< mm
  double top = 0.0;              ///< mm
  double radius = 2.0;           ///< mm
  double spacing = 0.25;         ///< mm
};
/// The slab's leaves; `material_of` picks each leaf's material from its tangent point on the plane.
std::vector<LeafSphere> slab(const SlabSpec& spec, const std::function<uint16_t(const Vec3&)>& material_of);

/// A collision object from leaves.
CollisionObject object(const std::string& name, const std::vector<LeafSphere>& leaves, ObjectKind kind,
                       int16_t lesion = -1);

/// A model with these objects and materials, the straight probe and default gains/limits.
Model model(std::vector<CollisionObject> objects, std::vector<Material> materials);

/// Rigid, frictionless enamel.
Material enamel();
/// Compliant tissue of stiffness k (N/mm), frictionless unless mu_s/mu_d are set.
Material soft(double k, double mu_s = 0.0, double mu_d = 0.0, Tissue tissue = Tissue::Generic);

/// The probe pointing straight down (tool +z = world +z), tip centre at p.
Pose probe_at(const Vec3& p);

/// The collision stage of one sub-step bounded by `trans` mm and `rot` rad, run on its own: the leaf
/// margins, then the pairs at g (every object: the step's mask) into s.pairs.
void collect(const Model& m, StateImpl& s, const Pose& g, double trans, double rot = 0.0);

/// The built-in real-arch scene's model, built once per test program through the build tree's test
/// tree cache.
const Model& real_arch();

/// Smallest gap (mm) between any tool leaf and any leaf of the rigid objects (rigid_objects), capped
/// at 1 mm.
double rigid_clearance(const Model& m, const Pose& tool);

}  // namespace cariesim::test
