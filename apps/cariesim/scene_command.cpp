// `cariesim scene check FILE|NAME`: parses and validates a scene (and its mesh files) without
// building any tree; prints "ok" and a summary, or exits non-zero with the located error.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/scene/scene.hpp"
#include "commands.hpp"

namespace cariesim::cli {
namespace {

// "rigid" or "0.3 N/mm".
std::string stiffness_text(double stiffness) {
  return std::isfinite(stiffness) ? fmt::format("{:g} N/mm", stiffness) : std::string("rigid");
}

// Loads every mesh file to check its content; a bad mesh is reported at its scene entry.
void check_meshes(const SceneDesc& scene) {
  for (const ObjectDesc& o : scene.objects) {
    if (o.shape.kind != ShapeDesc::Kind::Mesh) continue;
    MeshReport report;
    MeshLoadOptions options;
    options.scale = o.shape.scale;
    try {
      (void)load_mesh(o.shape.file, &report, options);
    } catch (const Error& e) {
      throw Error(fmt::format("{}: object '{}': {}", o.where.str(), o.name, e.what()));
    }
    for (const auto& warning : report.warnings) {
      std::fprintf(stderr, "warning: %s: %s\n", o.shape.file.string().c_str(), warning.c_str());
    }
  }
}

// A note for each friction pair whose dynamic coefficient is above its static one: valid (the paper's
// Fig. 10 runs mu_s 0.2 with mu_d 0.3), but the tool then slips at mu_s, without stick-slip
// (docs/scene-format.md, "Friction"), which a reader of the file would not guess.
void note_friction(const std::string& where, const std::string& what, double mu_s, double mu_d) {
  if (mu_d > mu_s)
    std::fprintf(stderr,
                 "note: %s: %s: mu_d %g is above mu_s %g: sliding uses mu_s as the dynamic coefficient "
                 "too (no stick-slip); see docs/scene-format.md, Friction\n",
                 where.c_str(), what.c_str(), mu_d, mu_s);
}

void check_friction(const SceneDesc& scene) {
  for (const ObjectDesc& o : scene.objects)
    note_friction(o.where.str(), "object '" + o.name + "' material", o.material.mu_s, o.material.mu_d);
  for (const LesionDesc& l : scene.lesions) {
    note_friction(l.where.str(), "lesion '" + l.name + "' material", l.material.mu_s, l.material.mu_d);
    if (!l.material.aniso_dir.isZero())
      note_friction(l.where.str(), "lesion '" + l.name + "' material.anisotropic", l.material.mu_s_along,
                    l.material.mu_d_along);
  }
}

// The summary printed after "ok".
void print_summary(const SceneDesc& scene) {
  std::printf("ok: %s (%s)\n", scene.name.c_str(), scene.origin.c_str());
  std::printf("%zu objects, %zu lesions, %zu collision parts\n", scene.objects.size(), scene.lesions.size(),
              scene.objects.size() + scene.lesions.size());
  for (const ObjectDesc& o : scene.objects) {
    const std::string tooth = o.fdi != 0 ? fmt::format("FDI {}", o.fdi) : std::string("-");
    const std::string tree = o.tree.params.mode == TreeMode::Tight
                                 ? fmt::format("tight {:g} mm", o.tree.params.tolerance)
                                 : fmt::format("octree depth {}", o.tree.params.depth);
    const std::string source = o.shape.kind == ShapeDesc::Kind::Mesh
                                   ? o.shape.file.string()
                                   : std::string(shape_kind_name(o.shape.kind));
    std::printf("  object %-16s %-8s %-9s %-5s %-10s %s, %s\n", o.name.c_str(), tooth.c_str(),
                std::string(tissue_name(o.material.tissue)).c_str(),
                o.kind == ObjectKind::Rigid ? "rigid" : "soft", stiffness_text(o.material.stiffness).c_str(),
                source.c_str(), tree.c_str());
  }
  for (const LesionDesc& l : scene.lesions) {
    const std::string& host = scene.objects[static_cast<std::size_t>(l.object)].name;
    std::printf("  lesion %-16s on %-12s %s %g mm, %g mm deep, %s, mu_s %g mu_d %g k_e %g N/mm F_p* %g N\n",
                l.name.c_str(), host.c_str(), std::string(lesion_kind_name(l.shape.kind)).c_str(),
                l.shape.size, l.shape.depth, l.severity.empty() ? "no preset" : l.severity.c_str(),
                l.material.mu_s, l.material.mu_d, l.material.k_e, l.material.f_p_star);
  }
  std::printf("  tool   explorer, tip radius %g mm\n", scene.tool.tip_radius);
  std::printf("  device max %g N, %g N/mm, %g N·mm; coupling %g N/mm, %g N·mm/rad; servo %g Hz\n",
              scene.limits.max_force, scene.limits.max_stiffness, scene.limits.max_torque,
              scene.gains.k_trans, scene.gains.k_rot, scene.servo_rate);
}

}  // namespace

void register_scene(CLI::App& app, Registry& registry) {
  auto* scene = app.add_subcommand("scene", "Scene files");
  scene->require_subcommand(1);
  auto* check = scene->add_subcommand("check", "Validate a scene file or built-in scene (builds no trees)");
  auto target = std::make_shared<std::string>();
  check->add_option("scene", *target, "a scene YAML file or a built-in scene name")->required();
  registry.add(check, [target] {
    const SceneDesc desc = load_scene(*target);
    check_meshes(desc);
    check_friction(desc);
    print_summary(desc);
    return 0;
  });
}

}  // namespace cariesim::cli
