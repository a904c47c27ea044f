#pragma once
/// What the viewer draws of a model and a servo snapshot (docs/design.md §5): teeth, gingiva and tongue
/// shaded in tissue colours (soft tissue dented where the tool presses it), the graphic tool solid,
/// the haptic tool (and a replay's recorded tool) as translucent ghosts, and the overlays: sphere
/// trees by level, contacts, the virtual tunnel, the force arrow. Render thread only.
///
/// It copies what may change while the servo loop runs (the soft tissues' stiffness) when it is made,
/// and afterwards reads only the model's immutable parts (display meshes, trees, the tool).

#include <optional>
#include <string>
#include <vector>

#include "cariesim/render/model.hpp"
#include "cariesim/servo/servo.hpp"
#include "gl_renderer.hpp"
#include "soft_dent.hpp"

namespace cariesim::viewer {

/// The overlay and display toggles of the panel.
struct ViewSettings {
  bool show_lesions = false;   ///< caries drawn in caries colour (hidden: in the healthy colour)
  bool haptic_ghost = true;    ///< the haptic tool as a translucent ghost
  bool recorded_ghost = true;  ///< a replay's recorded (graphic) tool as a second ghost
  bool contacts = false;       ///< contact points and normals scaled by force
  bool tunnel = true;          ///< the five virtual-tunnel spheres while penetrating
  bool force_arrow = true;     ///< the force as an arrow at the tool tip
  bool dents = true;           ///< soft tissue dents
  /// The explorer's working end drawn faintly over everything, so that neither a tooth nor the
  /// tool's own handle hides the tip
  bool tip_xray = true;
  bool trees = false;                 ///< sphere trees at `tree_level`
  int tree_level = 4;                 ///< level of the tree cut shown (0 = root)
  int tree_object = -1;               ///< -1: every object, -2: the tool, else a Model::objects index
  float arrow_mm_per_newton = 8.0f;   ///< mm of arrow per N of force
  float normal_mm_per_newton = 4.0f;  ///< mm of contact normal per N of contact force
};

/// Tissue colours (linear RGB, opaque).
Rgba tissue_color(Tissue tissue);
/// The background colour of the 3-D view.
Rgba background_color();
/// The solid (graphic) tool's colour.
Rgba tool_color();

class SceneView {
 public:
  /// Uploads the model's display meshes and the tool (GL context current). `model` must outlive it.
  explicit SceneView(const Model& model);

  /// Draws the scene for a snapshot; `recorded` is a replay's recorded graphic pose, if any.
  void draw(GlRenderer& renderer, const ServoSnapshot& snapshot, const ViewSettings& settings,
            const std::optional<Pose>& recorded);

  /// Bounds of the display parts (mm, world).
  [[nodiscard]] const Eigen::AlignedBox3d& bounds() const { return bounds_; }
  /// Deepest tree level over the objects and the tool (the level slider's range).
  [[nodiscard]] int max_tree_level() const { return max_level_; }
  /// The colour a collision object is drawn in with these settings (hidden caries: its host's).
  [[nodiscard]] Rgba object_color(int object, const ViewSettings& settings) const;
  /// The tissue whose colour an object is drawn in with these settings.
  [[nodiscard]] Tissue object_display_tissue(int object, const ViewSettings& settings) const;
  /// Points on the tool's centre line (tool frame, mm), every ~10 mm from the tip to the handle end.
  [[nodiscard]] const std::vector<Vec3>& tool_axis_points() const { return tool_axis_points_; }
  /// The tool's sections (tool frame, mm), every ~2 mm from the tip to the handle end, with its radius.
  [[nodiscard]] const std::vector<ToolSection>& tool_sections() const { return tool_sections_; }
  /// Vertices moved by the last frame's dents.
  [[nodiscard]] std::size_t dented_vertices() const { return dented_vertices_; }

 private:
  struct Part {
    GlMesh mesh;
    Tissue tissue = Tissue::Generic;
    int lesion = -1;
    int object = -1;
    bool soft = false;
    bool cut = false;  // a part of an object that lesions cut: drawn while they are revealed
    bool has_whole = false;
    GlMesh whole;  // the cut object's uncut surface: drawn (on its healthy part) while they are hidden
    std::vector<Vec3f> base;    // undeformed vertices (soft parts)
    std::vector<Vec3f> dented;  // scratch
    bool was_dented = false;
  };
  struct TreeCut {
    int level = -1;
    std::vector<SphereInstance> spheres;
  };
  void update_dents(const ServoSnapshot& snapshot, bool enabled);
  const std::vector<SphereInstance>& tree_spheres(int object, int level);

  const Model& model_;
  std::vector<Part> parts_;
  std::vector<double> soft_stiffness_;  // per object, N/mm (0 for rigid)
  std::vector<Tissue> host_tissue_;     // per object: the tissue drawn for hidden caries
  std::vector<Tissue> own_tissue_;      // per object: its display tissue
  GlMesh tool_mesh_, arrow_mesh_;
  std::vector<std::vector<uint8_t>> levels_;  // per object, then the tool last
  std::vector<TreeCut> cuts_;                 // per object, then the tool last
  std::vector<Vec3> tool_axis_points_;
  std::vector<ToolSection> tool_sections_;
  std::vector<SphereInstance> working_end_;  // the tool's sphere chain near the tip, tool frame
  Eigen::AlignedBox3d bounds_;
  int max_level_ = 0;
  std::size_t dented_vertices_ = 0;
  std::vector<Dent> dents_scratch_;
};

}  // namespace cariesim::viewer
