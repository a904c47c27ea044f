#include "gl_renderer.hpp"

#include <epoxy/gl.h>

#include <cmath>
#include <map>
#include <string>
#include <utility>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/nearest.hpp"

namespace cariesim::viewer {

namespace {

// Lit meshes and instanced spheres: a head light a little above the eye, a fill light from above
// (so surfaces seen at grazing angles still show), a touch of specular; two-sided so that open or
// inverted surfaces still shade. u_inflate pushes vertices out along their normals (mm).
constexpr const char* kMeshVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_instance;
uniform mat4 u_model;
uniform mat4 u_view_proj;
uniform bool u_instanced;
uniform float u_inflate;
out vec3 v_world;
out vec3 v_normal;
void main() {
  vec3 local = u_instanced ? a_instance.xyz + a_instance.w * a_position : a_position + u_inflate * a_normal;
  vec4 world = u_model * vec4(local, 1.0);
  v_world = world.xyz;
  v_normal = mat3(u_model) * a_normal;
  gl_Position = u_view_proj * world;
}
)";

constexpr const char* kMeshFragment = R"(#version 330 core
in vec3 v_world;
in vec3 v_normal;
uniform vec4 u_color;
uniform vec3 u_eye;
out vec4 frag_color;
void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_eye - v_world);
  if (dot(n, v) < 0.0) n = -n;
  vec3 key = normalize(v + vec3(0.0, 0.0, 0.5));
  vec3 fill = normalize(vec3(-0.3, 0.4, 1.0));
  float diffuse = max(dot(n, key), 0.0);
  float fill_diffuse = max(dot(n, fill), 0.0);
  float specular = pow(max(dot(n, normalize(key + v)), 0.0), 40.0);
  vec3 c = u_color.rgb * (0.26 + 0.52 * diffuse + 0.30 * fill_diffuse) + vec3(0.2) * specular;
  frag_color = vec4(min(c, vec3(1.0)), u_color.a);
}
)";

constexpr const char* kLineVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_color;
uniform mat4 u_view_proj;
out vec4 v_color;
void main() {
  v_color = a_color;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)";

constexpr const char* kLineFragment = R"(#version 330 core
in vec4 v_color;
out vec4 frag_color;
void main() { frag_color = v_color; }
)";

// Compiles one shader stage; throws with the driver's log.
GLuint compile(GLenum type, const char* source) {
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    glDeleteShader(shader);
    throw Error(std::string("viewer: shader does not compile: ") + log);
  }
  return shader;
}

// Links a program from a vertex and a fragment shader; throws with the driver's log.
GLuint link(const char* vertex, const char* fragment) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, fragment);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    glDeleteProgram(program);
    throw Error(std::string("viewer: shader program does not link: ") + log);
  }
  return program;
}

// A unit icosphere: an icosahedron with each face split in four, `levels` times.
TriangleMesh make_unit_sphere(int levels) {
  TriangleMesh m;
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  const float raw[12][3] = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (const auto& v : raw) m.vertices.push_back(Vec3f(v[0], v[1], v[2]).normalized());
  m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    const auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
      const auto index = static_cast<uint32_t>(m.vertices.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<uint32_t, 3>> next;
    for (const auto& tri : m.triangles) {
      const uint32_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]),
                     ca = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  return m;
}

// Interleaves positions and normals (6 floats per vertex).
void interleave(std::span<const Vec3f> vertices, std::span<const Vec3f> normals, std::vector<float>& out) {
  out.resize(vertices.size() * 6);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      out[6 * i + k] = vertices[i][k];
      out[6 * i + 3 + k] = normals[i][k];
    }
  }
}

}  // namespace

std::vector<Vec3f> vertex_normals(std::span<const Vec3f> vertices,
                                  std::span<const std::array<uint32_t, 3>> triangles) {
  // The geometry module's area-weighted normals (nearest.hpp), in float, +z where a vertex has none.
  const std::vector<Vec3> unit = cariesim::vertex_normals(vertices, triangles);
  std::vector<Vec3f> normals(unit.size());
  for (std::size_t i = 0; i < unit.size(); ++i)
    normals[i] = unit[i].squaredNorm() > 0.0 ? Vec3f(unit[i].cast<float>()) : Vec3f::UnitZ();
  return normals;
}

Mat4f pose_matrix(const Pose& pose) {
  Mat4f m = Mat4f::Identity();
  m.block<3, 3>(0, 0) = pose.q.normalized().toRotationMatrix().cast<float>();
  m.block<3, 1>(0, 3) = pose.p.cast<float>();
  return m;
}

TriangleMesh make_arrow_mesh() {
  // A 16-sided shaft (radius 0.035) from z = 0 to 0.75 and a cone (radius 0.1) from 0.75 to 1.
  constexpr int kSides = 16;
  TriangleMesh m;
  const auto ring = [&](float z, float r) {
    const auto first = static_cast<uint32_t>(m.vertices.size());
    for (int i = 0; i < kSides; ++i) {
      const float a = 2.0f * static_cast<float>(M_PI) * static_cast<float>(i) / kSides;
      m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), z);
    }
    return first;
  };
  const uint32_t base = ring(0.0f, 0.035f), neck = ring(0.75f, 0.035f), collar = ring(0.75f, 0.1f);
  m.vertices.emplace_back(0.0f, 0.0f, 1.0f);
  const auto apex = static_cast<uint32_t>(m.vertices.size() - 1);
  for (uint32_t i = 0; i < kSides; ++i) {
    const uint32_t j = (i + 1) % kSides;
    m.triangles.push_back({base + i, base + j, neck + j});
    m.triangles.push_back({base + i, neck + j, neck + i});
    m.triangles.push_back({neck + i, neck + j, collar + j});
    m.triangles.push_back({neck + i, collar + j, collar + i});
    m.triangles.push_back({collar + i, collar + j, apex});
  }
  return m;
}

GlMesh::GlMesh(const TriangleMesh& mesh) : triangles_(mesh.triangles) {
  // Interleaved positions and normals, and the index buffer.
  interleave(mesh.vertices, vertex_normals(mesh.vertices, mesh.triangles), interleaved_);
  glGenVertexArrays(1, &vao_);
  glGenBuffers(1, &vbo_);
  glGenBuffers(1, &ebo_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved_.size() * sizeof(float)),
               interleaved_.data(), GL_DYNAMIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(triangles_.size() * sizeof(triangles_[0])),
               triangles_.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glBindVertexArray(0);
  index_count_ = static_cast<int>(triangles_.size() * 3);
}

GlMesh::~GlMesh() { release(); }

GlMesh::GlMesh(GlMesh&& other) noexcept { *this = std::move(other); }

GlMesh& GlMesh::operator=(GlMesh&& other) noexcept {
  if (this == &other) return *this;
  release();
  vao_ = std::exchange(other.vao_, 0);
  vbo_ = std::exchange(other.vbo_, 0);
  ebo_ = std::exchange(other.ebo_, 0);
  index_count_ = std::exchange(other.index_count_, 0);
  triangles_ = std::move(other.triangles_);
  interleaved_ = std::move(other.interleaved_);
  return *this;
}

void GlMesh::release() {
  if (vao_ != 0) glDeleteVertexArrays(1, &vao_);
  if (vbo_ != 0) glDeleteBuffers(1, &vbo_);
  if (ebo_ != 0) glDeleteBuffers(1, &ebo_);
  vao_ = vbo_ = ebo_ = 0;
  index_count_ = 0;
}

void GlMesh::update_positions(std::span<const Vec3f> vertices) {
  if (vertices.size() * 6 != interleaved_.size()) return;
  interleave(vertices, vertex_normals(vertices, triangles_), interleaved_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(interleaved_.size() * sizeof(float)),
                  interleaved_.data());
}

void GlMesh::draw() const {
  if (index_count_ == 0) return;
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

GlRenderer::GlRenderer() {
  // Programs and their uniforms.
  mesh_program_ = link(kMeshVertex, kMeshFragment);
  line_program_ = link(kLineVertex, kLineFragment);
  u_model_ = glGetUniformLocation(mesh_program_, "u_model");
  u_view_proj_ = glGetUniformLocation(mesh_program_, "u_view_proj");
  u_color_ = glGetUniformLocation(mesh_program_, "u_color");
  u_eye_ = glGetUniformLocation(mesh_program_, "u_eye");
  u_instanced_ = glGetUniformLocation(mesh_program_, "u_instanced");
  u_inflate_ = glGetUniformLocation(mesh_program_, "u_inflate");
  u_line_view_proj_ = glGetUniformLocation(line_program_, "u_view_proj");

  // The unit sphere (80 triangles: the overlays draw tens of thousands of them) with an instance
  // buffer of (centre, radius) per sphere at attribute 2.
  const TriangleMesh sphere = make_unit_sphere(1);
  std::vector<float> data;
  interleave(sphere.vertices, sphere.vertices, data);
  glGenVertexArrays(1, &sphere_vao_);
  glGenBuffers(1, &sphere_vbo_);
  glGenBuffers(1, &sphere_ebo_);
  glGenBuffers(1, &instance_vbo_);
  glBindVertexArray(sphere_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, sphere_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, sphere_ebo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(sphere.triangles.size() * sizeof(sphere.triangles[0])),
               sphere.triangles.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, instance_vbo_);
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, sizeof(SphereInstance), nullptr);
  glVertexAttribDivisor(2, 1);
  glBindVertexArray(0);
  sphere_index_count_ = static_cast<int>(sphere.triangles.size() * 3);

  // Lines: position and colour per vertex, refilled per draw.
  glGenVertexArrays(1, &line_vao_);
  glGenBuffers(1, &line_vbo_);
  glBindVertexArray(line_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(LineVertex),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glBindVertexArray(0);
}

GlRenderer::~GlRenderer() {
  glDeleteProgram(mesh_program_);
  glDeleteProgram(line_program_);
  glDeleteVertexArrays(1, &sphere_vao_);
  glDeleteBuffers(1, &sphere_vbo_);
  glDeleteBuffers(1, &sphere_ebo_);
  glDeleteBuffers(1, &instance_vbo_);
  glDeleteVertexArrays(1, &line_vao_);
  glDeleteBuffers(1, &line_vbo_);
}

void GlRenderer::begin(const FrameParams& frame) {
  view_proj_ = frame.projection * frame.view;
  eye_ = frame.eye;
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
}

void GlRenderer::set_blend(const Rgba& color) {
  // Opaque: depth writes, no blending. Translucent: blend over what is drawn, keep its depth.
  if (color[3] < 1.0f) {
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
  } else {
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
  }
}

void GlRenderer::draw_mesh(const GlMesh& mesh, const Pose& pose, const Rgba& color, float inflate) {
  draw_mesh(mesh, pose_matrix(pose), color, inflate);
}

void GlRenderer::draw_mesh(const GlMesh& mesh, const Mat4f& model, const Rgba& color, float inflate) {
  glUseProgram(mesh_program_);
  glUniformMatrix4fv(u_model_, 1, GL_FALSE, model.data());
  glUniformMatrix4fv(u_view_proj_, 1, GL_FALSE, view_proj_.data());
  glUniform4fv(u_color_, 1, color.data());
  const Vec3f eye = eye_.cast<float>();
  glUniform3fv(u_eye_, 1, eye.data());
  glUniform1i(u_instanced_, 0);
  glUniform1f(u_inflate_, inflate);
  glVertexAttrib4f(2, 0.0f, 0.0f, 0.0f, 1.0f);
  set_blend(color);
  mesh.draw();
  glDepthMask(GL_TRUE);
}

void GlRenderer::draw_spheres(std::span<const SphereInstance> spheres, const Pose& pose, const Rgba& color,
                              bool on_top) {
  if (spheres.empty()) return;
  glUseProgram(mesh_program_);
  const Mat4f model = pose_matrix(pose);
  glUniformMatrix4fv(u_model_, 1, GL_FALSE, model.data());
  glUniformMatrix4fv(u_view_proj_, 1, GL_FALSE, view_proj_.data());
  glUniform4fv(u_color_, 1, color.data());
  const Vec3f eye = eye_.cast<float>();
  glUniform3fv(u_eye_, 1, eye.data());
  glUniform1i(u_instanced_, 1);
  glUniform1f(u_inflate_, 0.0f);
  set_blend(color);
  glBindVertexArray(sphere_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, instance_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(spheres.size() * sizeof(SphereInstance)),
               spheres.data(), GL_STREAM_DRAW);
  if (on_top) glDisable(GL_DEPTH_TEST);
  glDrawElementsInstanced(GL_TRIANGLES, sphere_index_count_, GL_UNSIGNED_INT, nullptr,
                          static_cast<GLsizei>(spheres.size()));
  glEnable(GL_DEPTH_TEST);
  glBindVertexArray(0);
  glDepthMask(GL_TRUE);
}

void GlRenderer::draw_lines(std::span<const LineVertex> vertices, bool on_top) {
  if (vertices.empty()) return;
  glUseProgram(line_program_);
  glUniformMatrix4fv(u_line_view_proj_, 1, GL_FALSE, view_proj_.data());
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  if (on_top) glDisable(GL_DEPTH_TEST);
  glBindVertexArray(line_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(LineVertex)),
               vertices.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(vertices.size()));
  glBindVertexArray(0);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
}

}  // namespace cariesim::viewer
