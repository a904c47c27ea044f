// The one rule for a rigid object (render/model.hpp): every leaf of a known, rigid material, and at
// least one leaf; the step's overlap re-check, the model builder and the experiments all use it.
#include "cariesim/render/model.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "render_support.hpp"

namespace cariesim {
namespace {

// Materials: 0 rigid enamel, 1 compliant gingiva, 2 rigid dentin.
std::vector<Material> three_materials() {
  Material dentin = test::enamel();
  dentin.tissue = Tissue::Dentin;
  return {test::enamel(), test::soft(0.3, 0.0, 0.0, Tissue::Gingiva), dentin};
}

// A row of leaves 1 mm apart, one per listed material.
CollisionObject row(const std::vector<uint16_t>& materials) {
  std::vector<LeafSphere> leaves;
  for (std::size_t i = 0; i < materials.size(); ++i)
    leaves.push_back({Vec3f(static_cast<float>(i), 0.0f, 0.0f), 0.6f, materials[i]});
  return test::object("row", leaves, ObjectKind::Rigid);
}

TEST(RigidObject, EveryLeafOfARigidMaterial) {
  const std::vector<Material> materials = three_materials();
  EXPECT_TRUE(rigid_object(row({0, 0, 2, 0}).tree, materials)) << "enamel and dentin are both rigid";
  EXPECT_FALSE(rigid_object(row({0, 0, 1, 0}).tree, materials)) << "one compliant leaf";
  EXPECT_FALSE(rigid_object(row({1, 1, 1, 1}).tree, materials));
  EXPECT_FALSE(rigid_object(row({0, 0, 3, 0}).tree, materials)) << "a material the table does not hold";
  EXPECT_FALSE(rigid_object(SphereTree{}, materials)) << "an empty tree";
}

TEST(RigidObject, TheModelsMaskFollowsItsMaterialsNotTheKind) {
  // Object 1 is drawn soft but all of its leaves are rigid; object 2 is drawn rigid but compliant.
  std::vector<CollisionObject> objects{row({0, 2, 0, 2}), row({0, 0, 0, 0}), row({1, 0, 0, 0})};
  objects[1].kind = ObjectKind::Soft;
  const Model m = test::model(std::move(objects), three_materials());
  EXPECT_EQ(rigid_objects(m), ObjectMask{0b011});
  Model soft = m;
  soft.defaults.materials[2] = test::soft(5.0);
  EXPECT_EQ(rigid_objects(soft), ObjectMask{0b010}) << "dentin made compliant";
}

}  // namespace
}  // namespace cariesim
