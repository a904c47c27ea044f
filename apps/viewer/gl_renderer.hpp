#pragma once
/// OpenGL 3.3 core drawing for the viewer (through libepoxy): lit triangle meshes, instanced spheres
/// (sphere-tree overlays, contacts, the virtual tunnel) and coloured lines (normals, the force arrow).
/// Every call needs the window's GL context current on the calling (render) thread.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "camera.hpp"
#include "cariesim/geometry/mesh.hpp"

namespace cariesim::viewer {

using Rgba = std::array<float, 4>;  ///< linear colour and opacity, each in [0, 1]

/// Per-vertex normals of a triangle mesh (area-weighted face normals, unit; +z where undefined).
std::vector<Vec3f> vertex_normals(std::span<const Vec3f> vertices,
                                  std::span<const std::array<uint32_t, 3>> triangles);

/// A triangle mesh on the GPU; positions can be replaced (soft-tissue dents).
class GlMesh {
 public:
  GlMesh() = default;
  explicit GlMesh(const TriangleMesh& mesh);
  ~GlMesh();
  GlMesh(GlMesh&& other) noexcept;
  GlMesh& operator=(GlMesh&& other) noexcept;
  GlMesh(const GlMesh&) = delete;
  GlMesh& operator=(const GlMesh&) = delete;

  /// Replaces the vertex positions (same count as at creation) and recomputes the normals.
  void update_positions(std::span<const Vec3f> vertices);
  void draw() const;
  [[nodiscard]] bool empty() const { return index_count_ == 0; }

 private:
  void release();
  unsigned vao_ = 0, vbo_ = 0, ebo_ = 0;
  int index_count_ = 0;
  std::vector<std::array<uint32_t, 3>> triangles_;  // kept for normal updates
  std::vector<float> interleaved_;                  // position + normal per vertex, reused
};

/// One sphere instance: centre (mm) and radius (mm).
struct SphereInstance {
  std::array<float, 3> center{};  ///< mm, in the frame the draw call places
  float radius = 0.0f;            ///< mm
};
static_assert(sizeof(SphereInstance) == 4 * sizeof(float), "instance buffer layout");

/// One end of a coloured line segment.
struct LineVertex {
  std::array<float, 3> position{};  ///< mm, world
  Rgba color{};                     ///< colour and opacity
};
static_assert(sizeof(LineVertex) == 7 * sizeof(float), "line buffer layout");

/// A line vertex at a world point.
inline LineVertex line_vertex(const Vec3& p, const Rgba& color) {
  return {{static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())}, color};
}

/// Light and view for one frame.
struct FrameParams {
  Mat4f view = Mat4f::Identity();
  Mat4f projection = Mat4f::Identity();
  Vec3 eye = Vec3::Zero();  ///< mm, world
};

class GlRenderer {
 public:
  /// Compiles the shaders and makes the unit sphere; throws cariesim::Error with the GL log on failure.
  GlRenderer();
  ~GlRenderer();
  GlRenderer(const GlRenderer&) = delete;
  GlRenderer& operator=(const GlRenderer&) = delete;

  /// Sets the camera for the draws that follow.
  void begin(const FrameParams& frame);
  /// Draws a mesh placed by `pose` (object -> world) in a colour, its vertices pushed `inflate` mm out
  /// along their normals; translucent colours blend and do not write depth, so draw them after the
  /// opaque ones.
  void draw_mesh(const GlMesh& mesh, const Pose& pose, const Rgba& color, float inflate = 0.0f);
  /// As above with any object -> world matrix (e.g. a scaled arrow).
  void draw_mesh(const GlMesh& mesh, const Mat4f& model, const Rgba& color, float inflate = 0.0f);
  /// Draws spheres placed by `pose` (their frame -> world) in one colour.
  void draw_spheres(std::span<const SphereInstance> spheres, const Pose& pose, const Rgba& color,
                    bool on_top = false);
  /// Draws line segments (pairs of vertices), in world coordinates, over or behind the scene.
  void draw_lines(std::span<const LineVertex> vertices, bool on_top);

 private:
  void set_blend(const Rgba& color);
  unsigned mesh_program_ = 0, line_program_ = 0;
  int u_model_ = -1, u_view_proj_ = -1, u_color_ = -1, u_eye_ = -1, u_instanced_ = -1, u_inflate_ = -1;
  int u_line_view_proj_ = -1;
  unsigned sphere_vao_ = 0, sphere_vbo_ = 0, sphere_ebo_ = 0, instance_vbo_ = 0;
  int sphere_index_count_ = 0;
  unsigned line_vao_ = 0, line_vbo_ = 0;
  Mat4f view_proj_ = Mat4f::Identity();
  Vec3 eye_ = Vec3::Zero();
};

/// The 4 x 4 matrix of a pose (object -> world).
Mat4f pose_matrix(const Pose& pose);

/// A unit arrow along +z from the origin (length 1: a shaft, then a cone from 0.75 to 1).
TriangleMesh make_arrow_mesh();

}  // namespace cariesim::viewer
