#include "render/render_support.hpp"

#include <cmath>
#include <filesystem>
#include <limits>

#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/build.hpp"
#include "render/pairs.hpp"
#include "render/state_impl.hpp"

namespace cariesim::test {

std::vector<ToolSphere> straight_probe() {
  std::vector<ToolSphere> out;
  // Tip segment: radius grows linearly 0.05 -> 0.5 mm over 3 mm, spheres 0.02 mm apart near the tip.
  double z = 0.0;
  while (z < 3.0) {
    const double r = 0.05 + 0.45 * z / 3.0;
    out.push_back({Vec3(0, 0, z), r, 0});
    z += std::max(0.02, 0.3 * r);
  }
  // Shank: 1 mm radius.
  for (z = 3.5; z <= 40.0; z += 0.5) out.push_back({Vec3(0, 0, z), 1.0, 2});
  return out;
}

std::vector<LeafSphere> slab(const SlabSpec& spec, const std::function<uint16_t(const Vec3&)>& material_of) {
  std::vector<LeafSphere> leaves;
  for (double x = spec.x0; x <= spec.x1 + 1e-9; x += spec.spacing) {
    for (double y = spec.y0; y <= spec.y1 + 1e-9; y += spec.spacing) {
      LeafSphere leaf;
      leaf.center = Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(spec.top - spec.radius));
      leaf.radius = static_cast<float>(spec.radius);
      leaf.material = material_of(Vec3(x, y, spec.top));
      leaf.flags = kLeafOnExposedSurface;
      leaf.depth = static_cast<float>(spec.radius);
      leaf.tangents.normal[0] = Vec3f::UnitZ();
      leaf.tangents.count = 1;
      leaves.push_back(leaf);
    }
  }
  return leaves;
}

CollisionObject object(const std::string& name, const std::vector<LeafSphere>& leaves, ObjectKind kind,
                       int16_t lesion) {
  CollisionObject o;
  o.name = name;
  o.tree = build_hierarchy(leaves, 4);
  o.kind = kind;
  o.lesion = lesion;
  return o;
}

Model model(std::vector<CollisionObject> objects, std::vector<Material> materials) {
  Model m;
  m.objects = std::move(objects);
  m.defaults.materials = std::move(materials);
  m.tool.tree = build_tool_tree(straight_probe());
  m.tool.tip_radius = 0.05;
  m.tool_home = probe_at(Vec3(0, 0, 50));
  m.defaults.gains.k_trans = 1.0;
  m.defaults.gains.k_rot = 150.0;
  return m;
}

Material enamel() {
  Material m;
  m.tissue = Tissue::Enamel;
  return m;
}

Material soft(double k, double mu_s, double mu_d, Tissue tissue) {
  Material m;
  m.tissue = tissue;
  m.stiffness = k;
  m.mu_s = mu_s;
  m.mu_d = mu_d;
  return m;
}

Pose probe_at(const Vec3& p) { return Pose{p, Quat::Identity()}; }

double rigid_clearance(const Model& m, const Pose& tool) {
  // The collision module's branch-and-bound closest pair (checked against brute force in its tests).
  PlacedTool placed(m.tool.tree);
  placed.place(tool, 0.0);
  const ClosestPair c = closest(placed, m.objects, rigid_objects(m), 1.0);
  return std::isfinite(c.gap) ? c.gap : 1.0;
}

void collect(const Model& m, StateImpl& s, const Pose& g, double trans, double rot) {
  detail::set_leaf_margins(m, trans, rot, s.collision);
  detail::collect_pairs(m, s.constants, s.collision, g, s.constants.all_mask, s.pairs);
}

const Model& real_arch() {
  static const Model model = [] {
    BuildOptions o;
    o.cache_dir = std::filesystem::path(CARIESIM_BINARY_DIR) / "test-cache";
    return build_model(load_scene("real-arch"), o);
  }();
  return model;
}

}  // namespace cariesim::test
