#include "scene_view.hpp"

#include <algorithm>
#include <cmath>

#include "cariesim/geometry/procedural.hpp"
#include "tree_levels.hpp"

namespace cariesim::viewer {

namespace {

constexpr Rgba kHapticGhost{0.35f, 0.80f, 1.00f, 0.35f};
constexpr Rgba kRecordedGhost{1.00f, 0.65f, 0.20f, 0.35f};
constexpr Rgba kTunnel{1.00f, 0.90f, 0.20f, 0.30f};
constexpr Rgba kContactPoint{1.00f, 0.20f, 0.20f, 1.00f};
constexpr Rgba kContactNormal{1.00f, 0.30f, 0.30f, 1.00f};
constexpr Rgba kForceArrow{0.95f, 0.25f, 0.15f, 1.00f};
constexpr Rgba kWorkingEndXray{0.85f, 0.87f, 0.92f, 0.40f};
constexpr double kWorkingEnd = 12.0;     // mm of the explorer from its tip drawn over everything
constexpr float kCariesInflate = 0.08f;  // mm

// Overlay colours of the sphere trees by kind of object.
Rgba tree_color(const CollisionObject& object) {
  if (object.lesion >= 0) return {0.85f, 0.45f, 0.15f, 0.30f};
  if (object.kind == ObjectKind::Soft) return {0.90f, 0.35f, 0.55f, 0.25f};
  return {0.30f, 0.65f, 0.95f, 0.25f};
}

// The rotation taking +z onto a direction.
Quat rotation_to(const Vec3& direction) {
  return Quat::FromTwoVectors(Vec3::UnitZ(), direction.normalized());
}

}  // namespace

Rgba tissue_color(Tissue tissue) {
  switch (tissue) {
    case Tissue::Enamel:
      return {0.93f, 0.89f, 0.78f, 1.0f};
    case Tissue::Dentin:
      return {0.90f, 0.80f, 0.58f, 1.0f};
    case Tissue::Caries:
      return {0.42f, 0.25f, 0.10f, 1.0f};
    case Tissue::Gingiva:
      return {0.86f, 0.44f, 0.50f, 1.0f};
    case Tissue::Tongue:
      return {0.78f, 0.36f, 0.40f, 1.0f};
    case Tissue::Generic:
      return {0.60f, 0.70f, 0.86f, 1.0f};
  }
  return {0.7f, 0.7f, 0.7f, 1.0f};
}

Rgba background_color() { return {0.16f, 0.18f, 0.22f, 1.0f}; }

Rgba tool_color() { return {0.62f, 0.64f, 0.68f, 1.0f}; }

SceneView::SceneView(const Model& model) : model_(model) {
  // Per object: its own display tissue, its soft stiffness (copied now: materials may change later).
  const std::size_t n = model.objects.size();
  own_tissue_.assign(n, Tissue::Generic);
  host_tissue_.assign(n, Tissue::Generic);
  soft_stiffness_.assign(n, 0.0);
  for (const DisplayPart& part : model.display)
    if (part.object >= 0 && static_cast<std::size_t>(part.object) < n) own_tissue_[part.object] = part.tissue;
  for (std::size_t o = 0; o < n; ++o) {
    const CollisionObject& object = model.objects[o];
    host_tissue_[o] = own_tissue_[o];
    if (object.host >= 0 && static_cast<std::size_t>(object.host) < n)
      host_tissue_[o] = own_tissue_[object.host];
    if (object.kind == ObjectKind::Soft && !object.tree.leaf_nodes.empty()) {
      const SphereNode& leaf = object.tree.nodes[object.tree.leaf_nodes.front()];
      if (leaf.material < model.defaults.materials.size())
        soft_stiffness_[o] = model.defaults.materials[leaf.material].stiffness;
    }
  }

  // The display parts on the GPU; soft parts keep their undeformed vertices for dents.
  for (const DisplayPart& part : model.display) {
    Part p;
    p.mesh = GlMesh(part.mesh);
    p.tissue = part.tissue;
    p.lesion = part.lesion;
    p.object = part.object;
    p.cut = part.cut;
    p.has_whole = !part.whole.triangles.empty();
    if (p.has_whole) p.whole = GlMesh(part.whole);
    p.soft =
        part.object >= 0 && static_cast<std::size_t>(part.object) < n && soft_stiffness_[part.object] > 0.0;
    if (p.soft) p.base = part.mesh.vertices;
    // The bounds of what is drawn with the lesions hidden: an object that lesions cut by its uncut
    // surface (its parts' surfaces differ from it by a lesion's shape, so framing on them would move
    // the camera by where the lesions are).
    if (p.has_whole)
      bounds_.extend(part.whole.bounds());
    else if (!p.cut)
      bounds_.extend(part.mesh.bounds());
    parts_.push_back(std::move(p));
  }
  tool_mesh_ = GlMesh(model.tool.display);
  arrow_mesh_ = GlMesh(make_arrow_mesh());

  // Tree levels per object and for the tool (last).
  for (const CollisionObject& object : model.objects) levels_.push_back(node_levels(object.tree));
  levels_.push_back(node_levels(model.tool.tree));
  cuts_.resize(levels_.size());
  for (const auto& levels : levels_)
    if (!levels.empty())
      max_level_ = std::max(max_level_, static_cast<int>(*std::max_element(levels.begin(), levels.end())));

  // Points every ~10 mm along the tool's centre line (from its sphere chain, tip first).
  const std::vector<ToolSphere> chain = make_explorer_spheres(model.tool.params, 0.05);
  // The sections every ~2 mm (the camera's line of sight past the handle, camera.hpp).
  double along = 0.0, next = 0.0, next_section = 0.0;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    if (i > 0) along += (chain[i].center - chain[i - 1].center).norm();
    if (along >= next) {
      tool_axis_points_.push_back(chain[i].center);
      next += 10.0;
    }
    if (along >= next_section) {
      tool_sections_.push_back({chain[i].center, chain[i].radius});
      next_section += 2.0;
    }
    // The working end: the chain's first kWorkingEnd mm.
    if (along <= kWorkingEnd) {
      const Vec3& c = chain[i].center;
      working_end_.push_back(
          {{static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())},
           static_cast<float>(chain[i].radius)});
    }
  }
}

Tissue SceneView::object_display_tissue(int object, const ViewSettings& settings) const {
  if (object < 0 || static_cast<std::size_t>(object) >= own_tissue_.size()) return Tissue::Generic;
  const bool caries = model_.objects[object].lesion >= 0;
  return caries && !settings.show_lesions ? host_tissue_[object] : own_tissue_[object];
}

Rgba SceneView::object_color(int object, const ViewSettings& settings) const {
  return tissue_color(object_display_tissue(object, settings));
}

void SceneView::update_dents(const ServoSnapshot& snapshot, bool enabled) {
  dented_vertices_ = 0;
  for (Part& part : parts_) {
    if (!part.soft) continue;
    // This part's dents: contact reports on its collision object.
    dents_scratch_.clear();
    const int count = std::clamp(snapshot.out.contact_report_count, 0, kMaxReportedContacts);
    for (int i = 0; enabled && i < count; ++i) {
      const ContactReport& c = snapshot.out.contact_reports[i];
      Dent dent;
      if (c.object == part.object && dent_from_contact(c, soft_stiffness_[part.object], dent))
        dents_scratch_.push_back(dent);
    }
    // Move the vertices (or put them back once the tool has left).
    if (dents_scratch_.empty() && !part.was_dented) continue;
    part.dented.resize(part.base.size());
    dented_vertices_ += apply_dents(part.base, dents_scratch_, part.dented);
    part.mesh.update_positions(part.dented);
    part.was_dented = !dents_scratch_.empty();
  }
}

const std::vector<SphereInstance>& SceneView::tree_spheres(int index, int level) {
  // The cut at `level` of an object's tree (index < objects) or the tool's (the last index), cached.
  TreeCut& cut = cuts_[index];
  if (cut.level == level) return cut.spheres;
  const bool tool = static_cast<std::size_t>(index) == model_.objects.size();
  const SphereTree& tree = tool ? model_.tool.tree : model_.objects[index].tree;
  cut.level = level;
  cut.spheres.clear();
  for (const uint32_t i : level_cut(tree, levels_[index], level)) {
    const SphereNode& node = tree.nodes[i];
    cut.spheres.push_back({{node.center.x(), node.center.y(), node.center.z()}, node.radius});
  }
  return cut.spheres;
}

void SceneView::draw(GlRenderer& renderer, const ServoSnapshot& snapshot, const ViewSettings& settings,
                     const std::optional<Pose>& recorded) {
  const StepOutput& out = snapshot.out;
  update_dents(snapshot, settings.dents);

  // Opaque: the tissues (an object that lesions cut drawn whole while they are hidden, so that no
  // seam outlines them; revealed, its parts in their colours), the graphic tool, the force arrow.
  for (const Part& part : parts_) {
    if (part.cut && !settings.show_lesions) {
      if (part.has_whole) renderer.draw_mesh(part.whole, Pose{}, object_color(part.object, settings));
      continue;
    }
    const Rgba color =
        part.object >= 0
            ? object_color(part.object, settings)
            : tissue_color(part.lesion >= 0 && !settings.show_lesions ? Tissue::Enamel : part.tissue);
    renderer.draw_mesh(part.mesh, Pose{}, color, part.lesion >= 0 ? kCariesInflate : 0.0f);
  }
  renderer.draw_mesh(tool_mesh_, out.graphic, tool_color());
  const Vec3 force = out.force;
  if (settings.force_arrow && force.allFinite() && force.norm() > 1e-3) {
    const double length = std::max(1.0, force.norm() * settings.arrow_mm_per_newton);
    Mat4f m = pose_matrix(Pose{out.graphic.p, rotation_to(force)});
    m.block<3, 3>(0, 0) *= static_cast<float>(length);
    renderer.draw_mesh(arrow_mesh_, m, kForceArrow);
  }
  if (settings.contacts) {
    std::vector<SphereInstance> points;
    const int count = std::clamp(out.contact_report_count, 0, kMaxReportedContacts);
    for (int i = 0; i < count; ++i) {
      const Vec3& p = out.contact_reports[i].point;
      points.push_back(
          {{static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())}, 0.12f});
    }
    renderer.draw_spheres(points, Pose{}, kContactPoint);
  }

  // Translucent: sphere trees, the tunnel, the ghosts.
  if (settings.trees) {
    const bool tool = settings.tree_object == -2;
    for (std::size_t o = 0; o < model_.objects.size() && !tool; ++o)
      if (settings.tree_object < 0 || settings.tree_object == static_cast<int>(o))
        renderer.draw_spheres(tree_spheres(static_cast<int>(o), settings.tree_level), Pose{},
                              tree_color(model_.objects[o]));
    if (tool || settings.tree_object == -1)
      renderer.draw_spheres(tree_spheres(static_cast<int>(model_.objects.size()), settings.tree_level),
                            out.graphic, {0.7f, 0.9f, 0.4f, 0.35f});
  }
  if (settings.tunnel && out.tunnel.active) {
    std::vector<SphereInstance> spheres;
    for (std::size_t i = 0; i < out.tunnel.centers.size(); ++i) {
      const Vec3& c = out.tunnel.centers[i];
      spheres.push_back({{static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())},
                         static_cast<float>(out.tunnel.radii[i])});
    }
    renderer.draw_spheres(spheres, Pose{}, kTunnel);
  }
  const bool apart =
      (out.haptic.p - out.graphic.p).norm() > 0.02 || out.haptic.q.angularDistance(out.graphic.q) > 0.005;
  if (settings.haptic_ghost && apart && out.haptic.finite())
    renderer.draw_mesh(tool_mesh_, out.haptic, kHapticGhost);
  if (settings.recorded_ghost && recorded && recorded->finite())
    renderer.draw_mesh(tool_mesh_, *recorded, kRecordedGhost);

  // The working end over everything (its tip never hidden by a tooth or the handle).
  if (settings.tip_xray) renderer.draw_spheres(working_end_, out.graphic, kWorkingEndXray, true);

  // Lines over everything: contact normals scaled by force.
  if (settings.contacts) {
    std::vector<LineVertex> lines;
    const int count = std::clamp(out.contact_report_count, 0, kMaxReportedContacts);
    for (int i = 0; i < count; ++i) {
      const ContactReport& c = out.contact_reports[i];
      const double length = std::max(0.5, c.force * settings.normal_mm_per_newton);
      lines.push_back(line_vertex(c.point, kContactNormal));
      lines.push_back(line_vertex(c.point + c.normal * length, kContactNormal));
    }
    renderer.draw_lines(lines, true);
  }
}

}  // namespace cariesim::viewer
