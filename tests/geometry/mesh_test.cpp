#include "cariesim/geometry/mesh.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstring>
#include <random>

#include "cariesim/common/error.hpp"
#include "geometry/mesh_test_util.hpp"
#include "support/fifo.hpp"

namespace cariesim {
namespace {

using test::temp_dir;
using test::unit_cube;
using test::write_file;
using ::testing::AllOf;
using ::testing::HasSubstr;

// The message of the cariesim::Error that load_mesh throws (fails the test when none is thrown).
std::string load_error(const std::filesystem::path& file, const MeshLoadOptions& options = {}) {
  try {
    (void)load_mesh(file, nullptr, options);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "load_mesh(" << file << ") did not throw";
  return {};
}

// Two tetrahedra: the unit-ish tetra and a copy shifted by `offset` along x.
TriangleMesh tetrahedron(float shift = 0.0f) {
  TriangleMesh m;
  m.vertices = {{shift, 0, 0}, {shift + 1, 0, 0}, {shift, 1, 0}, {shift, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TEST(TriangleMesh, MeasuresTheUnitCube) {
  const TriangleMesh cube = unit_cube();
  EXPECT_NEAR(cube.volume(), 1.0, 1e-12);
  EXPECT_NEAR(cube.area(), 6.0, 1e-12);
  const auto box = cube.bounds();
  EXPECT_TRUE(box.min().isApprox(Vec3(0, 0, 0)));
  EXPECT_TRUE(box.max().isApprox(Vec3(1, 1, 1)));
}

TEST(TriangleMesh, EmptyMeshHasZeroBounds) {
  const TriangleMesh empty;
  EXPECT_EQ(empty.bounds().min(), Vec3::Zero());
  EXPECT_EQ(empty.bounds().max(), Vec3::Zero());
  EXPECT_EQ(empty.volume(), 0.0);
}

TEST(TriangleMesh, TransformIsRigid) {
  TriangleMesh cube = unit_cube();
  Pose pose;
  pose.p = Vec3(10, -2, 3);
  pose.q = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  cube.transform(pose);
  EXPECT_NEAR(cube.volume(), 1.0, 1e-5);
  EXPECT_NEAR(cube.area(), 6.0, 1e-5);
  EXPECT_TRUE(cube.vertices[0].cast<double>().isApprox(pose.p, 1e-6));
}

TEST(LoadMesh, MissingFileIsNamed) {
  const auto file = temp_dir() / "no_such_tooth.stl";
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("no_such_tooth.stl"), HasSubstr("not found")));
}

// Issue 26 item 13: a FIFO named like a mesh is refused by its kind, without blocking; /dev/zero too.
TEST(LoadMesh, AFifoOrADeviceIsNamedByItsKind) {
  const auto fifo = temp_dir() / ("pipe_" + std::to_string(::getpid()) + ".stl");
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::FifoOutcome outcome = test::read_fifo(fifo, [fifo] { (void)load_mesh(fifo); });
  std::filesystem::remove(fifo);
  EXPECT_FALSE(outcome.blocked);
  EXPECT_THAT(outcome.error, HasSubstr("mesh: not a regular file (a FIFO (named pipe))"));
  EXPECT_THAT(load_error("/dev/zero"), HasSubstr("/dev/zero: mesh: not a regular file (a character device)"));
}

// Issue #14 item 9: a directory (here one named like a mesh) was "unsupported" or "not a regular file".
TEST(LoadMesh, ADirectoryIsNamedAsSuch) {
  const auto dir = temp_dir() / "folder.stl";
  std::filesystem::create_directories(dir);
  EXPECT_THAT(load_error(dir),
              AllOf(HasSubstr("folder.stl"), HasSubstr("mesh: not a regular file (a folder)")));
  std::filesystem::remove(dir);
}

TEST(LoadMesh, EmptyFileIsRejected) {
  const auto file = write_file(temp_dir() / "empty.stl", "");
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("empty.stl"), HasSubstr("empty")));
}

TEST(LoadMesh, UnsupportedExtensionIsRejected) {
  const auto file = write_file(temp_dir() / "tooth.xyz", "1 2 3\n");
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("tooth.xyz"), HasSubstr("unsupported")));
}

TEST(LoadMesh, TruncatedBinaryStlIsRejected) {
  const auto dir = temp_dir();
  const auto good = dir / "cube.stl";
  save_stl(unit_cube(), good);
  const std::string bytes = test::read_file(good);
  ASSERT_EQ(bytes.size(), 84u + 12u * 50u);
  const auto file = write_file(dir / "cut.stl", bytes.substr(0, bytes.size() - 30));
  EXPECT_THAT(load_error(file),
              AllOf(HasSubstr("cut.stl"), HasSubstr("truncated"), HasSubstr("12 triangles")));
  const auto header_only = write_file(dir / "stub.stl", bytes.substr(0, 50));
  EXPECT_THAT(load_error(header_only), AllOf(HasSubstr("stub.stl"), HasSubstr("truncated")));
}

TEST(LoadMesh, BinaryStlWithZeroTrianglesIsRejected) {
  const auto file = write_file(temp_dir() / "none.stl", std::string(84, '\0'));
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("none.stl"), HasSubstr("no triangles")));
}

TEST(LoadMesh, NanVertexInAsciiStlIsNamed) {
  std::string text = test::ascii_stl(unit_cube());
  const auto at = text.find("vertex ", text.find("facet", 200)) + 7;
  text.replace(at, text.find(' ', at) - at, "nan");
  const auto file = write_file(temp_dir() / "nan.stl", text);
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("nan.stl"), HasSubstr("non-finite"), HasSubstr("triangle")));
}

TEST(LoadMesh, NanVertexInObjIsNamed) {
  std::string text = test::obj_text(unit_cube());
  const auto at = text.find("v ", text.find("v ") + 1) + 2;  // second vertex, x coordinate
  text.replace(at, text.find(' ', at) - at, "nan");
  const auto file = write_file(temp_dir() / "nan.obj", text);
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("nan.obj"), HasSubstr("non-finite")));
}

TEST(LoadMesh, InfinityInBinaryStlIsNamed) {
  const auto dir = temp_dir();
  save_stl(unit_cube(), dir / "cube.stl");
  std::string bytes = test::read_file(dir / "cube.stl");
  const float inf = std::numeric_limits<float>::infinity();
  // Triangle 5, second corner, y coordinate: 84 + 5*50 + 12 (normal) + 12 (corner 0) + 4.
  std::memcpy(bytes.data() + 84 + 5 * 50 + 12 + 12 + 4, &inf, sizeof(inf));
  const auto file = write_file(dir / "inf.stl", bytes);
  EXPECT_THAT(load_error(file),
              AllOf(HasSubstr("inf.stl"), HasSubstr("non-finite"), HasSubstr("triangle 5")));
}

TEST(LoadMesh, OpenMeshIsRejected) {
  TriangleMesh open = unit_cube();
  open.triangles.resize(10);  // the x = 1 face is missing
  const auto file = write_file(temp_dir() / "open.obj", test::obj_text(open));
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("open.obj"), HasSubstr("open mesh"), HasSubstr("boundary")));

  // Accepted, with the count, when closed meshes are not required.
  MeshLoadOptions lenient;
  lenient.require_closed = false;
  MeshReport report;
  const TriangleMesh mesh = load_mesh(file, &report, lenient);
  EXPECT_EQ(mesh.triangles.size(), 10u);
  EXPECT_EQ(report.boundary_edges, 4u);
  EXPECT_FALSE(report.watertight());
}

TEST(LoadMesh, NonManifoldMeshIsRejected) {
  // Two tetrahedra sharing the edge from (0,0,0) to (0,0,1): four triangles on that edge.
  TriangleMesh m = tetrahedron();
  TriangleMesh other;
  other.vertices = {{0, 0, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
  other.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  for (const auto& v : other.vertices) m.vertices.push_back(v);
  for (const auto& t : other.triangles) m.triangles.push_back({t[0] + 4, t[1] + 4, t[2] + 4});
  const auto file = write_file(temp_dir() / "bowtie.obj", test::obj_text(m));
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("bowtie.obj"), HasSubstr("non-manifold")));
}

TEST(LoadMesh, NoTrianglesIsRejected) {
  const auto file = write_file(temp_dir() / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("points.obj"), HasSubstr("no triangles")));
}

TEST(LoadMesh, AllDegenerateIsRejected) {
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  flat.triangles = {{0, 1, 2}, {1, 2, 3}, {0, 0, 3}};
  const auto file = write_file(temp_dir() / "line.stl", test::ascii_stl(flat));
  EXPECT_THAT(load_error(file), AllOf(HasSubstr("line.stl"), HasSubstr("degenerate")));
}

TEST(LoadMesh, GarbageBytesGiveAnError) {
  const auto dir = temp_dir();
  std::mt19937 rng(7);
  std::string junk(3000, '\0');
  for (auto& c : junk) c = static_cast<char>(rng() & 0xff);
  for (const char* name : {"junk.stl", "junk.obj", "junk.ply"}) {
    const auto file = write_file(dir / name, junk);
    EXPECT_THAT(load_error(file), HasSubstr(name));
  }
  // Text that is almost a format.
  const auto ply = write_file(dir / "header.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
  EXPECT_THAT(load_error(ply), AllOf(HasSubstr("header.ply"), HasSubstr("end_header")));
  // A damaged end_header line once sent assimp's PLY reader into an endless loop.
  const auto merged =
      write_file(dir / "merged.ply",
                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nend_headerroperty float y\n0 0 0\n1 0 0\n0 1 0\n");
  EXPECT_THAT(load_error(merged), AllOf(HasSubstr("merged.ply"), HasSubstr("line 7")));
  const auto huge = write_file(dir / "huge.ply",
                               "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                               "property float x\nproperty float y\nproperty float z\nend_header\n0000");
  EXPECT_THAT(load_error(huge), AllOf(HasSubstr("huge.ply"), HasSubstr("truncated")));
}

TEST(LoadMesh, ReadsAsciiStlObjAndPly) {
  const auto dir = temp_dir();
  const TriangleMesh cube = unit_cube();
  for (const auto& [name, text] :
       {std::pair{"cube_ascii.stl", test::ascii_stl(cube)}, std::pair{"cube.obj", test::obj_text(cube)},
        std::pair{"cube.ply", test::ply_text(cube)}}) {
    MeshReport report;
    const TriangleMesh mesh = load_mesh(write_file(dir / name, text), &report);
    EXPECT_EQ(mesh.vertices.size(), 8u) << name;
    EXPECT_EQ(mesh.triangles.size(), 12u) << name;
    EXPECT_NEAR(mesh.volume(), 1.0, 1e-5) << name;
    EXPECT_TRUE(report.watertight()) << name;
    EXPECT_EQ(report.self_intersections, 0u) << name;
  }
}

TEST(LoadMesh, ObjQuadsAreTriangulated) {
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n"
      "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  const TriangleMesh mesh = load_mesh(write_file(temp_dir() / "quads.obj", text));
  EXPECT_EQ(mesh.triangles.size(), 12u);
  EXPECT_NEAR(mesh.volume(), 1.0, 1e-6);
}

TEST(LoadMesh, ScaleMultipliesCoordinates) {
  MeshLoadOptions options;
  options.scale = 10.0;
  const TriangleMesh mesh =
      load_mesh(write_file(temp_dir() / "cm.obj", test::obj_text(unit_cube())), nullptr, options);
  EXPECT_NEAR(mesh.volume(), 1000.0, 1e-3);
  options.scale = -1.0;
  EXPECT_THAT(load_error(temp_dir() / "cm.obj", options), HasSubstr("scale"));
}

TEST(SaveStl, RoundTripsThroughLoadMesh) {
  const auto dir = temp_dir();
  TriangleMesh cube = unit_cube();
  Pose pose;
  pose.p = Vec3(3, 4, 5);
  pose.q = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  cube.transform(pose);
  save_stl(cube, dir / "out.stl");
  MeshReport report;
  const TriangleMesh back = load_mesh(dir / "out.stl", &report);
  ASSERT_EQ(back.triangles.size(), cube.triangles.size());
  ASSERT_EQ(back.vertices.size(), cube.vertices.size());
  EXPECT_NEAR(back.volume(), cube.volume(), 1e-5);
  EXPECT_NEAR(back.area(), cube.area(), 1e-5);
  EXPECT_FALSE(report.flipped);
  EXPECT_EQ(report.reoriented, 0u);
  // Every vertex comes back exactly (float storage both ways).
  for (const auto& v : cube.vertices) {
    const bool found =
        std::any_of(back.vertices.begin(), back.vertices.end(), [&](const Vec3f& w) { return w == v; });
    EXPECT_TRUE(found) << v.transpose();
  }
}

TEST(SaveStl, UnwritablePathIsNamed) {
  const auto file = temp_dir() / "no_dir" / "x.stl";
  try {
    save_stl(unit_cube(), file);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("x.stl"));
  }
}

TEST(ValidateMesh, WeldsDropsAndOrients) {
  // Unshared corners (like STL), one triangle turned, one repeated-index triangle.
  const TriangleMesh cube = unit_cube();
  TriangleMesh soup;
  for (const auto& t : cube.triangles) {
    const auto base = static_cast<uint32_t>(soup.vertices.size());
    for (const auto v : t) soup.vertices.push_back(cube.vertices[v]);
    soup.triangles.push_back({base, base + 1, base + 2});
  }
  std::swap(soup.triangles[3][1], soup.triangles[3][2]);
  soup.triangles.push_back({0, 0, 5});
  MeshReport report;
  validate_mesh(soup, "soup", &report);
  EXPECT_EQ(report.input_triangles, 13u);
  EXPECT_EQ(report.duplicates_merged, 36u - 8u);
  EXPECT_EQ(report.degenerate_removed, 1u);
  EXPECT_EQ(report.reoriented, 1u);
  EXPECT_FALSE(report.flipped);
  EXPECT_TRUE(report.watertight());
  EXPECT_EQ(soup.vertices.size(), 8u);
  EXPECT_EQ(soup.triangles.size(), 12u);
  EXPECT_NEAR(soup.volume(), 1.0, 1e-12);
  EXPECT_FALSE(report.warnings.empty());
}

TEST(ValidateMesh, TurnsAnInsideOutMeshOutward) {
  TriangleMesh cube = unit_cube();
  for (auto& t : cube.triangles) std::swap(t[0], t[1]);
  ASSERT_LT(cube.volume(), 0.0);
  MeshReport report;
  validate_mesh(cube, "inside-out", &report);
  EXPECT_TRUE(report.flipped);
  EXPECT_NEAR(cube.volume(), 1.0, 1e-12);
}

TEST(ValidateMesh, SplitsTheNeighbourOfACapTriangle) {
  // The cube's top face split so that a zero-area triangle (4, 8, 5) sits on the edge 4-5 with its
  // corner 8 at the edge's middle; the face across that edge still spans 4-5.
  TriangleMesh cube = unit_cube();
  cube.vertices.emplace_back(0.5f, 0.0f, 1.0f);  // vertex 8 on edge 4-5
  // Top face (z = 1): replace (4,5,6) by (4,8,6) and (8,5,6); add the cap (4,5,8) walking 4->5.
  cube.triangles[2] = {4, 8, 6};
  cube.triangles.push_back({8, 5, 6});
  cube.triangles.push_back({4, 5, 8});
  MeshReport report;
  validate_mesh(cube, "cap", &report);
  EXPECT_EQ(report.degenerate_removed, 1u);
  EXPECT_TRUE(report.watertight());
  EXPECT_EQ(cube.triangles.size(), 14u);  // 12 + 1 from the split top + 1 from the split side
  EXPECT_NEAR(cube.volume(), 1.0, 1e-6);
}

TEST(ValidateMesh, FillsASmallHoleButNotAMissingSide) {
  // A 10x10 grid per face cube: removing the two triangles of one cell leaves a 4-edge hole.
  TriangleMesh box;
  const int n = 10;
  auto grid_index = [&](int i, int j, int k) {
    return static_cast<uint32_t>((k * (n + 1) + j) * (n + 1) + i);
  };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) box.vertices.emplace_back(float(i), float(j), float(k));
  // Faces z = n (outward +z) and the others by a generic quad emitter.
  auto quad = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    box.triangles.push_back({a, b, c});
    box.triangles.push_back({a, c, d});
  };
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      quad(grid_index(a, b, n), grid_index(a + 1, b, n), grid_index(a + 1, b + 1, n),
           grid_index(a, b + 1, n));
      quad(grid_index(a, b, 0), grid_index(a, b + 1, 0), grid_index(a + 1, b + 1, 0),
           grid_index(a + 1, b, 0));
      quad(grid_index(a, 0, b), grid_index(a + 1, 0, b), grid_index(a + 1, 0, b + 1),
           grid_index(a, 0, b + 1));
      quad(grid_index(a, n, b), grid_index(a, n, b + 1), grid_index(a + 1, n, b + 1),
           grid_index(a + 1, n, b));
      quad(grid_index(0, a, b), grid_index(0, a, b + 1), grid_index(0, a + 1, b + 1),
           grid_index(0, a + 1, b));
      quad(grid_index(n, a, b), grid_index(n, a + 1, b), grid_index(n, a + 1, b + 1),
           grid_index(n, a, b + 1));
    }
  {
    TriangleMesh closed = box;
    MeshReport report;
    validate_mesh(closed, "grid box", &report);
    ASSERT_TRUE(report.watertight());
    ASSERT_NEAR(closed.volume(), 1000.0, 1e-9);
  }
  TriangleMesh holed = box;
  holed.triangles.erase(holed.triangles.begin(), holed.triangles.begin() + 2);  // one top cell
  MeshReport report;
  validate_mesh(holed, "holed box", &report);
  EXPECT_EQ(report.holes_filled, 1u);
  EXPECT_TRUE(report.watertight());
  EXPECT_NEAR(holed.volume(), 1000.0, 1e-6);

  // A whole side missing is far too large to fill.
  TriangleMesh open = box;
  std::vector<std::array<uint32_t, 3>> kept;
  for (std::size_t t = 0; t < open.triangles.size(); ++t) {
    if (t % 12 >= 2) kept.push_back(open.triangles[t]);  // drop every top-face pair
  }
  open.triangles = kept;
  EXPECT_THROW(validate_mesh(open, "open box"), Error);
}

TEST(ValidateMesh, BadIndicesAndNanAreNamed) {
  TriangleMesh bad = unit_cube();
  bad.triangles[4][2] = 99;
  try {
    validate_mesh(bad, "my mesh");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("my mesh"), HasSubstr("triangle 4"), HasSubstr("vertex 99")));
  }
  TriangleMesh nan = unit_cube();
  nan.vertices[6].y() = std::numeric_limits<float>::quiet_NaN();
  try {
    validate_mesh(nan, "my mesh");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("my mesh"), HasSubstr("non-finite"), HasSubstr("vertex 6")));
  }
  TriangleMesh empty;
  EXPECT_THROW(validate_mesh(empty, "empty"), Error);
}

// Issue #14 item 9: a mesh in metres or micrometres read as millimetres (1 km, 1 µm across) was a
// warning, then a tree error about something else ("invalid tree: node 89 ...", "is empty").
TEST(ValidateMesh, SizesNoSceneCanHoldAreRefusedNamingTheUnits) {
  for (const double size : {1e6, 1e-3}) {
    TriangleMesh m = unit_cube();
    for (auto& v : m.vertices) v *= static_cast<float>(size);
    try {
      validate_mesh(m, "scan");
      FAIL() << size << " mm accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), AllOf(HasSubstr("scan: largest extent is"), HasSubstr("outside [0.1, 1000] mm"),
                                  HasSubstr("scale")));
    }
  }
  TriangleMesh fine = unit_cube();
  EXPECT_NO_THROW(validate_mesh(fine, "cube"));
}

TEST(ValidateMesh, CountsSelfIntersections) {
  // Two cubes overlapping: their faces cross.
  TriangleMesh a = unit_cube();
  TriangleMesh b = unit_cube();
  Pose shift;
  shift.p = Vec3(0.5, 0.25, 0.3);
  b.transform(shift);
  for (const auto& v : b.vertices) a.vertices.push_back(v);
  for (const auto& t : b.triangles) a.triangles.push_back({t[0] + 8, t[1] + 8, t[2] + 8});
  // Counted (a warning) where open meshes are allowed; refused for a closed solid (issue #14 item 9:
  // it was accepted with a warning and its tree poked out 2.2 mm).
  MeshLoadOptions open;
  open.require_closed = false;
  MeshReport report;
  TriangleMesh counted = a;
  validate_mesh(counted, "two cubes", &report, open);
  EXPECT_EQ(report.components, 2u);
  EXPECT_GT(report.self_intersections, 0u);
  try {
    validate_mesh(a, "two cubes", &report);
    FAIL() << "a self-intersecting solid was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("two cubes"), HasSubstr("the surface intersects itself")));
  }

  // Apart, they do not.
  TriangleMesh c = unit_cube();
  TriangleMesh d = unit_cube();
  shift.p = Vec3(2, 0, 0);
  d.transform(shift);
  for (const auto& v : d.vertices) c.vertices.push_back(v);
  for (const auto& t : d.triangles) c.triangles.push_back({t[0] + 8, t[1] + 8, t[2] + 8});
  validate_mesh(c, "two cubes apart", &report);
  EXPECT_EQ(report.self_intersections, 0u);
}

TEST(LoadMesh, SpheresCrossingExactlyAlongEdgesAreRefused) {
  // Two equal spheres 3 mm apart on x (radius 2 mm) are mirror images of each other: every point
  // where their surfaces cross lies exactly on an edge of each. Counted as crossing and refused (they
  // were accepted, and the tree poked 2.73 mm out of the union).
  const auto dir = temp_dir();
  const TriangleMesh pair =
      test::merged(test::uv_sphere(Vec3(0, 0, 0), 2.0), test::uv_sphere(Vec3(3, 0, 0), 2.0));
  save_stl(pair, dir / "spheres.stl");
  for (const auto& [name, bytes] :
       {std::pair<std::string, std::string>{"spheres.stl", test::read_file(dir / "spheres.stl")},
        {"spheres.ply", test::binary_ply(pair)}}) {
    const auto file = write_file(dir / name, bytes);
    EXPECT_THAT(load_error(file), AllOf(HasSubstr(file.string()), HasSubstr("the surface intersects itself")))
        << name;
    MeshLoadOptions open;
    open.require_closed = false;
    MeshReport report;
    (void)load_mesh(file, &report, open);
    EXPECT_GT(report.self_intersections, 0u) << name;
  }
  // Apart (4.5 mm), the same spheres load, as two shells.
  save_stl(test::merged(test::uv_sphere(Vec3(0, 0, 0), 2.0), test::uv_sphere(Vec3(4.5, 0, 0), 2.0)),
           dir / "apart.stl");
  MeshReport report;
  (void)load_mesh(dir / "apart.stl", &report);
  EXPECT_EQ(report.components, 2u);
  EXPECT_EQ(report.self_intersections, 0u);
}

TEST(LoadMesh, AShellInsideAnotherIsRefusedNamingTheShells) {
  // A hollow ball: an outer sphere (5 mm) around a cavity (a 3 mm sphere wound inward), as a scan of a
  // tooth with its pulp chamber would be. It was made solid without a word; now it is refused, as is
  // a part inside another (both wound outward).
  const auto dir = temp_dir();
  const TriangleMesh outer = test::uv_sphere(Vec3(1, 2, 3), 5.0);
  for (const bool inward : {true, false}) {
    const TriangleMesh inner = test::uv_sphere(Vec3(1.5, 2, 3), 3.0, 16, 8, inward);
    for (const bool inner_first : {false, true}) {
      const TriangleMesh mesh = inner_first ? test::merged(inner, outer) : test::merged(outer, inner);
      save_stl(mesh, dir / "hollow.stl");
      const std::string message = load_error(dir / "hollow.stl");
      EXPECT_THAT(message, AllOf(HasSubstr((dir / "hollow.stl").string()),
                                 HasSubstr(inner_first ? "shell 1 (224 triangles) lies inside shell 2 (528 "
                                                       : "shell 2 (224 triangles) lies inside shell 1 (528 "),
                                 HasSubstr("inner cavity")))
          << "inward " << inward << ", inner first " << inner_first;
    }
  }
  // Side by side, the two shells load.
  save_stl(test::merged(outer, test::uv_sphere(Vec3(12, 2, 3), 3.0)), dir / "two.stl");
  MeshReport report;
  (void)load_mesh(dir / "two.stl", &report);
  EXPECT_EQ(report.components, 2u);
}

TEST(ValidateMesh, ManyShellsWithinOneAnothersBoundsAreRefusedNotCheckedForMinutes) {
  // 3000 small tetrahedra in three corners of a fine sphere's bounds, outside the sphere: checking
  // each against the sphere would take 3000 x 3 x 5000 triangle tests; the check gives up, saying why.
  TriangleMesh mesh = test::uv_sphere(Vec3(0, 0, 0), 20.0, 100, 26);
  for (int i = 0; i < 3000; ++i) {
    TriangleMesh t = tetrahedron();
    for (auto& v : t.vertices) v *= 0.5f;
    const double sign = i < 1000 ? 1.0 : -1.0;
    const int k = i % 1000;
    Pose at;
    at.p = sign * Vec3(14.0 + 0.55 * (k % 10), 14.0 + 0.55 * (k / 10 % 10), 14.0 + 0.55 * (k / 100)) +
           (sign < 0.0 ? Vec3(-0.5, -0.5, i < 2000 ? -0.5 : 30.0) : Vec3::Zero());
    t.transform(at);
    mesh = test::merged(std::move(mesh), t);
  }
  try {
    validate_mesh(mesh, "packed shells");
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("packed shells"), HasSubstr("3001 separate shells")));
  }
}

// Real CBCT-segmented teeth (open-full-jaw, patient 26): tooth_19 = FDI 36, tooth_30 = FDI 46.
class RealScan : public ::testing::TestWithParam<const char*> {};

TEST_P(RealScan, LoadsWatertightWithPlausibleSize) {
  const std::filesystem::path file =
      std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / GetParam();
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shipped scan missing: " << file;
  MeshReport report;
  const TriangleMesh mesh = load_mesh(file, &report);
  for (const auto& w : report.warnings) std::cout << GetParam() << ": " << w << "\n";
  const Vec3 size = mesh.bounds().sizes();
  std::cout << GetParam() << ": " << mesh.triangles.size() << " triangles, " << mesh.vertices.size()
            << " vertices, bounds " << size.transpose() << " mm, volume " << mesh.volume() << " mm^3, area "
            << mesh.area() << " mm^2, self-intersections " << report.self_intersections << "\n";
  EXPECT_TRUE(report.watertight());
  EXPECT_EQ(report.components, 1u);
  EXPECT_GT(mesh.triangles.size(), 40000u);
  EXPECT_LT(mesh.triangles.size(), 50000u);
  // A closed genus-0 surface: V - E + F = 2 with E = 3F/2.
  EXPECT_EQ(static_cast<long>(mesh.vertices.size()) - static_cast<long>(mesh.triangles.size()) / 2, 2);
  // A lower molar with its roots: 10-25 mm across, 500-1500 mm^3.
  EXPECT_GT(size.minCoeff(), 8.0);
  EXPECT_LT(size.maxCoeff(), 25.0);
  EXPECT_GT(mesh.volume(), 500.0);
  EXPECT_LT(mesh.volume(), 1500.0);

  // In the tooth's own frame (axes shipped with the scans: centre c and the points c + x, c + y,
  // c + z), the crown (the top 7.5 mm) is 10-11 mm mesio-distally and bucco-lingually.
  const std::string tooth = std::string(GetParam()).substr(6, 2);
  const YAML::Node axes = YAML::LoadFile((file.parent_path() / "teeth_axes_mandible.json").string())[tooth];
  auto point = [&](const char* key) {
    return Vec3(axes[key][0].as<double>(), axes[key][1].as<double>(), axes[key][2].as<double>());
  };
  const Vec3 c = point("c");
  Mat3 frame;
  frame.row(0) = (point("x") - c).normalized();
  frame.row(1) = (point("y") - c).normalized();
  frame.row(2) = (point("z") - c).normalized();
  double top = -1e9;
  for (const auto& v : mesh.vertices) top = std::max(top, (frame * (v.cast<double>() - c)).z());
  Eigen::AlignedBox3d crown;
  for (const auto& v : mesh.vertices) {
    const Vec3 q = frame * (v.cast<double>() - c);
    if (q.z() > top - 7.5) crown.extend(q);
  }
  std::cout << GetParam() << ": crown " << crown.sizes().head<2>().transpose() << " mm in the tooth frame\n";
  EXPECT_GT(crown.sizes().x(), 9.5);
  EXPECT_LT(crown.sizes().x(), 12.0);
  EXPECT_GT(crown.sizes().y(), 9.5);
  EXPECT_LT(crown.sizes().y(), 12.0);
}

INSTANTIATE_TEST_SUITE_P(Patient26, RealScan, ::testing::Values("tooth_19.ply", "tooth_30.ply"));

}  // namespace
}  // namespace cariesim
