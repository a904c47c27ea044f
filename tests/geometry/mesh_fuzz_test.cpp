// Randomized mutation of small valid mesh files: load_mesh must either return a finite, closed mesh
// or throw cariesim::Error naming the file; any other outcome (crash, other exception) fails.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <random>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "geometry/mesh_test_util.hpp"

namespace cariesim {
namespace {

// Mutations per seed file; five seed files, so 1500 loads of files under 2 kB. The environment
// variables CARIESIM_FUZZ_ITERATIONS and CARIESIM_FUZZ_SEED allow longer local runs.
int iterations() {
  const char* env = std::getenv("CARIESIM_FUZZ_ITERATIONS");
  return env != nullptr && std::atoi(env) > 0 ? std::atoi(env) : 300;
}

// A binary little-endian PLY of the mesh.
std::string binary_ply(const TriangleMesh& m) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(m.vertices.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
      std::to_string(m.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& p : m.vertices) s.append(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
  for (const auto& t : m.triangles) {
    s.push_back('\3');
    for (const auto v : t) {
      const auto i = static_cast<int32_t>(v);
      s.append(reinterpret_cast<const char*>(&i), sizeof(i));
    }
  }
  return s;
}

// One random change: overwrite bytes, truncate, insert, delete, duplicate a span, or swap a digit.
std::string mutate(std::string bytes, std::mt19937& rng) {
  auto pick = [&](std::size_t n) {
    return n == 0 ? std::size_t{0} : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
  };
  const int kind = std::uniform_int_distribution<int>(0, 5)(rng);
  switch (kind) {
    case 0: {
      const std::size_t flips = 1 + pick(8);
      for (std::size_t i = 0; i < flips && !bytes.empty(); ++i)
        bytes[pick(bytes.size())] = static_cast<char>(rng());
      break;
    }
    case 1:
      bytes.resize(pick(bytes.size()));
      break;
    case 2: {
      std::string junk(1 + pick(16), '\0');
      for (auto& c : junk) c = static_cast<char>(rng());
      bytes.insert(pick(bytes.size() + 1), junk);
      break;
    }
    case 3:
      if (!bytes.empty()) bytes.erase(pick(bytes.size()), 1 + pick(32));
      break;
    case 4:
      if (!bytes.empty()) {
        const std::size_t at = pick(bytes.size());
        bytes.insert(pick(bytes.size()), bytes.substr(at, 1 + pick(64)));
      }
      break;
    default:
      for (auto& c : bytes) {
        if (c >= '0' && c <= '9' && pick(20) == 0) c = static_cast<char>('0' + pick(10));
      }
      break;
  }
  return bytes;
}

struct Seed {
  const char* name;
  std::string bytes;
};

TEST(LoadMeshFuzz, MutatedFilesLoadCleanlyOrThrowError) {
  const auto dir = test::temp_dir();
  const TriangleMesh cube = test::unit_cube();
  save_stl(cube, dir / "seed.stl");
  const std::vector<Seed> seeds = {{"fuzz_binary.stl", test::read_file(dir / "seed.stl")},
                                   {"fuzz_ascii.stl", test::ascii_stl(cube)},
                                   {"fuzz.obj", test::obj_text(cube)},
                                   {"fuzz_ascii.ply", test::ply_text(cube)},
                                   {"fuzz_binary.ply", binary_ply(cube)}};
  const char* seed_env = std::getenv("CARIESIM_FUZZ_SEED");
  std::mt19937 rng(seed_env != nullptr ? static_cast<unsigned>(std::atol(seed_env)) : 20240611u);
  const int n = iterations();
  std::size_t loaded = 0;
  std::size_t rejected = 0;
  for (const auto& seed : seeds) {
    // The unmutated seed must load.
    ASSERT_NO_THROW((void)load_mesh(test::write_file(dir / seed.name, seed.bytes))) << seed.name;
    for (int i = 0; i < n; ++i) {
      std::string bytes = mutate(seed.bytes, rng);
      if (i % 3 == 0) bytes = mutate(bytes, rng);
      const auto file = test::write_file(dir / seed.name, bytes);
      try {
        MeshReport report;
        const TriangleMesh mesh = load_mesh(file, &report);
        ++loaded;
        ASSERT_FALSE(mesh.triangles.empty()) << seed.name << " iteration " << i;
        ASSERT_TRUE(report.watertight()) << seed.name << " iteration " << i;
        for (const auto& v : mesh.vertices) ASSERT_TRUE(v.allFinite()) << seed.name << " iteration " << i;
        for (const auto& t : mesh.triangles) {
          for (const auto v : t) ASSERT_LT(v, mesh.vertices.size()) << seed.name << " iteration " << i;
        }
        ASSERT_TRUE(std::isfinite(mesh.volume()));
        ASSERT_GT(mesh.volume(), 0.0) << seed.name << " iteration " << i;
      } catch (const Error& e) {
        ++rejected;
        ASSERT_THAT(e.what(), ::testing::HasSubstr(seed.name)) << "iteration " << i;
      } catch (const std::exception& e) {
        FAIL() << seed.name << " iteration " << i << ": unexpected exception type: " << e.what();
      }
    }
  }
  std::cout << "mutated files: " << loaded << " loaded, " << rejected << " rejected\n";
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(loaded, 0u);
}

}  // namespace
}  // namespace cariesim
