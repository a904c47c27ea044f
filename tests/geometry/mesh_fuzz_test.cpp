// Randomized mutation of small valid mesh files: load_mesh must either return a finite, closed mesh
// or throw cariesim::Error naming the file; any other outcome (crash, other exception) fails.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

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

// Loads a mutated file: either a finite, closed mesh enclosing a volume, or a cariesim::Error naming
// the file; anything else fails. Returns whether it loaded.
bool load_cleanly_or_refuse(const std::filesystem::path& file, const std::string& context) {
  const std::string name = file.filename().string();
  try {
    MeshReport report;
    const TriangleMesh mesh = load_mesh(file, &report);
    EXPECT_FALSE(mesh.triangles.empty()) << context;
    EXPECT_TRUE(report.watertight()) << context;
    EXPECT_EQ(report.self_intersections, 0u) << context;
    for (const auto& v : mesh.vertices) EXPECT_TRUE(v.allFinite()) << context;
    for (const auto& t : mesh.triangles) {
      for (const auto v : t) EXPECT_LT(v, mesh.vertices.size()) << context;
    }
    EXPECT_TRUE(std::isfinite(mesh.volume())) << context;
    EXPECT_GT(mesh.volume(), 0.0) << context;
    return true;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr(name)) << context;
    return false;
  } catch (const std::exception& e) {
    ADD_FAILURE() << context << ": unexpected exception type: " << e.what();
    return false;
  }
}

std::mt19937 fuzz_rng() {
  const char* seed_env = std::getenv("CARIESIM_FUZZ_SEED");
  return std::mt19937(seed_env != nullptr ? static_cast<unsigned>(std::atol(seed_env)) : 20240611u);
}

TEST(LoadMeshFuzz, MutatedFilesLoadCleanlyOrThrowError) {
  const auto dir = test::temp_dir();
  const TriangleMesh cube = test::unit_cube();
  save_stl(cube, dir / "seed.stl");
  const std::vector<Seed> seeds = {{"fuzz_binary.stl", test::read_file(dir / "seed.stl")},
                                   {"fuzz_ascii.stl", test::ascii_stl(cube)},
                                   {"fuzz.obj", test::obj_text(cube)},
                                   {"fuzz_ascii.ply", test::ply_text(cube)},
                                   {"fuzz_binary.ply", test::binary_ply(cube)}};
  std::mt19937 rng = fuzz_rng();
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
      (load_cleanly_or_refuse(file, std::string(seed.name) + " iteration " + std::to_string(i)) ? loaded
                                                                                                : rejected)++;
      if (::testing::Test::HasFailure()) return;
    }
  }
  std::cout << "mutated files: " << loaded << " loaded, " << rejected << " rejected\n";
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(loaded, 0u);
}

TEST(LoadMeshFuzz, MutatedCrossingAndHollowMeshesLoadCleanlyOrThrowError) {
  // Seeds that are refused as they are: two equal spheres crossing exactly along edges, and a hollow
  // ball (a sphere around an inward-wound one). Mutated, they still load cleanly (never crossing,
  // never nested) or are refused naming the file.
  const auto dir = test::temp_dir();
  const TriangleMesh crossing =
      test::merged(test::uv_sphere(Vec3(0, 0, 0), 2.0, 12, 6), test::uv_sphere(Vec3(3, 0, 0), 2.0, 12, 6));
  const TriangleMesh hollow = test::merged(test::uv_sphere(Vec3(0, 0, 0), 5.0, 12, 6),
                                           test::uv_sphere(Vec3(0, 0, 0), 3.0, 8, 4, true));
  save_stl(hollow, dir / "hollow.stl");
  save_stl(crossing, dir / "crossing.stl");
  const std::vector<Seed> seeds = {{"crossing.ply", test::binary_ply(crossing)},
                                   {"crossing.stl", test::read_file(dir / "crossing.stl")},
                                   {"hollow.stl", test::read_file(dir / "hollow.stl")}};
  std::mt19937 rng = fuzz_rng();
  const int n = std::max(1, iterations() / 3);
  for (const auto& seed : seeds) {
    const auto original = test::write_file(dir / seed.name, seed.bytes);
    try {
      (void)load_mesh(original);
      ADD_FAILURE() << seed.name << " was accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(seed.name));
      EXPECT_THAT(e.what(), ::testing::AnyOf(::testing::HasSubstr("the surface intersects itself"),
                                             ::testing::HasSubstr("inner cavity")));
    }
    for (int i = 0; i < n; ++i) {
      std::string bytes = mutate(seed.bytes, rng);
      if (i % 3 == 0) bytes = mutate(bytes, rng);
      (void)load_cleanly_or_refuse(test::write_file(dir / seed.name, bytes),
                                   std::string(seed.name) + " iteration " + std::to_string(i));
      if (::testing::Test::HasFailure()) return;
    }
  }
}

}  // namespace
}  // namespace cariesim
