#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"

namespace cariesim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Highest point of a mesh over (x, y), found by intersecting vertical lines with its triangles
// (binned in xy); NaN where the line misses. Only triangles entirely above z_floor are considered.
class TopSurface {
 public:
  TopSurface(const TriangleMesh& mesh, double z_floor) : mesh_(mesh) {
    const auto box = mesh.bounds();
    origin_ = box.min().head<2>();
    nx_ = static_cast<int>(box.sizes().x() / kBin) + 1;
    ny_ = static_cast<int>(box.sizes().y() / kBin) + 1;
    bins_.resize(static_cast<std::size_t>(nx_ * ny_));
    for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      Eigen::AlignedBox2d b;
      bool above = true;
      for (const auto v : mesh.triangles[t]) {
        b.extend(mesh.vertices[v].head<2>().cast<double>());
        above = above && mesh.vertices[v].z() > z_floor;
      }
      if (!above) continue;
      for (int i = bin_x(b.min().x()); i <= bin_x(b.max().x()); ++i)
        for (int j = bin_y(b.min().y()); j <= bin_y(b.max().y()); ++j)
          bins_[static_cast<std::size_t>(j * nx_ + i)].push_back(t);
    }
  }

  [[nodiscard]] double height(double x, double y) const {
    double best = kNaN;
    for (const uint32_t t : bins_[static_cast<std::size_t>(bin_y(y) * nx_ + bin_x(x))]) {
      const auto& tri = mesh_.triangles[t];
      const Vec3 a = mesh_.vertices[tri[0]].cast<double>();
      const Vec3 b = mesh_.vertices[tri[1]].cast<double>();
      const Vec3 c = mesh_.vertices[tri[2]].cast<double>();
      const double det = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
      if (std::abs(det) < 1e-15) continue;
      const double u = ((x - a.x()) * (c.y() - a.y()) - (y - a.y()) * (c.x() - a.x())) / det;
      const double v = ((b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x())) / det;
      if (u < 0 || v < 0 || u + v > 1) continue;
      const double z = a.z() + u * (b.z() - a.z()) + v * (c.z() - a.z());
      if (std::isnan(best) || z > best) best = z;
    }
    return best;
  }

 private:
  static constexpr double kBin = 0.5;
  [[nodiscard]] int bin_x(double x) const {
    return std::clamp(static_cast<int>((x - origin_.x()) / kBin), 0, nx_ - 1);
  }
  [[nodiscard]] int bin_y(double y) const {
    return std::clamp(static_cast<int>((y - origin_.y()) / kBin), 0, ny_ - 1);
  }
  const TriangleMesh& mesh_;
  Eigen::Vector2d origin_;
  int nx_ = 0;
  int ny_ = 0;
  std::vector<std::vector<uint32_t>> bins_;
};

// Heights of the top surface on a regular grid.
struct HeightGrid {
  double x0, y0, step;
  int nx, ny;
  std::vector<double> h;
  [[nodiscard]] double at(int i, int j) const { return h[static_cast<std::size_t>(j * nx + i)]; }
  [[nodiscard]] Vec3 point(int i, int j) const { return {x0 + i * step, y0 + j * step, at(i, j)}; }
};

HeightGrid sample_top(const TriangleMesh& mesh, double z_floor, double step) {
  const TopSurface top(mesh, z_floor);
  const auto box = mesh.bounds();
  HeightGrid g{box.min().x(),
               box.min().y(),
               step,
               static_cast<int>(box.sizes().x() / step) + 1,
               static_cast<int>(box.sizes().y() / step) + 1,
               {}};
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) g.h.push_back(top.height(g.x0 + i * step, g.y0 + j * step));
  return g;
}

// Peaks of the top surface: samples that are the highest within `radius` (ties broken by index) and
// stand at least `prominence` above the lowest sample within 1.5 mm.
std::vector<Vec3> peaks(const HeightGrid& g, double radius, double prominence) {
  constexpr double kProminenceRadius = 1.5;  // mm
  std::vector<Vec3> out;
  const int r = static_cast<int>(std::ceil(std::max(radius, kProminenceRadius) / g.step));
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      const double h = g.at(i, j);
      if (std::isnan(h)) continue;
      bool is_peak = true;
      double low = h;
      for (int dj = -r; dj <= r && is_peak; ++dj) {
        for (int di = -r; di <= r; ++di) {
          const int ii = i + di;
          const int jj = j + dj;
          if ((di == 0 && dj == 0) || ii < 0 || jj < 0 || ii >= g.nx || jj >= g.ny) continue;
          const double d2 = (di * di + dj * dj) * g.step * g.step;
          const double o = g.at(ii, jj);
          if (std::isnan(o)) continue;
          if (d2 <= kProminenceRadius * kProminenceRadius) low = std::min(low, o);
          if (d2 > radius * radius) continue;
          const bool later = dj > 0 || (dj == 0 && di > 0);
          if (o > h || (o == h && !later)) {
            is_peak = false;
            break;
          }
        }
      }
      if (is_peak && h - low >= prominence) out.push_back(g.point(i, j));
    }
  }
  return out;
}

// Number of times the line {(t, y, z)} crosses the surface: twice the number of pieces it passes
// (callers pick y and z off the round values where mesh vertices may lie).
int crossings_along_x(const TriangleMesh& m, double y, double z) {
  int count = 0;
  for (const auto& tri : m.triangles) {
    const Vec3 a = m.vertices[tri[0]].cast<double>();
    const Vec3 b = m.vertices[tri[1]].cast<double>();
    const Vec3 c = m.vertices[tri[2]].cast<double>();
    const double det = (b.y() - a.y()) * (c.z() - a.z()) - (b.z() - a.z()) * (c.y() - a.y());
    if (std::abs(det) < 1e-15) continue;
    const double u = ((y - a.y()) * (c.z() - a.z()) - (z - a.z()) * (c.y() - a.y())) / det;
    const double v = ((b.y() - a.y()) * (z - a.z()) - (b.z() - a.z()) * (y - a.y())) / det;
    if (u >= 0 && v >= 0 && u + v <= 1) ++count;
  }
  return count;
}

double mean_edge(const TriangleMesh& m) {
  double sum = 0.0;
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) sum += (m.vertices[t[k]] - m.vertices[t[(k + 1) % 3]]).cast<double>().norm();
  }
  return sum / (3.0 * static_cast<double>(m.triangles.size()));
}

// Bounds of the vertices at or above z = 0 (the crown).
Eigen::AlignedBox3d crown_bounds(const TriangleMesh& m) {
  Eigen::AlignedBox3d b;
  for (const auto& v : m.vertices) {
    if (v.z() >= 0.0f) b.extend(v.cast<double>());
  }
  return b;
}

void expect_closed_and_clean(const TriangleMesh& mesh, const char* what) {
  TriangleMesh copy = mesh;
  MeshReport report;
  ASSERT_NO_THROW(validate_mesh(copy, what, &report)) << what;
  EXPECT_TRUE(report.watertight()) << what;
  EXPECT_EQ(report.components, 1u) << what;
  EXPECT_EQ(report.self_intersections, 0u) << what;
  EXPECT_FALSE(report.flipped) << what << " was not wound outward";
  EXPECT_EQ(report.reoriented, 0u) << what;
  EXPECT_EQ(copy.triangles.size(), mesh.triangles.size()) << what << " needed repairs";
  EXPECT_GT(mesh.volume(), 0.0) << what;
}

class MolarShape : public ::testing::TestWithParam<MolarParams> {};

TEST_P(MolarShape, IsClosedAndHasTheRequestedDimensions) {
  const MolarParams p = GetParam();
  const TriangleMesh molar = make_molar(p);
  expect_closed_and_clean(molar, "molar");

  // Crown: mesio-distal and bucco-lingual extents and height within 1 mm; roots reach -root_length.
  const auto crown = crown_bounds(molar);
  std::cout << "molar " << molar.triangles.size() << " triangles, crown " << crown.sizes().transpose()
            << " mm, volume " << molar.volume() << " mm^3, mean edge " << mean_edge(molar) << " mm\n";
  EXPECT_NEAR(crown.sizes().x(), p.mesiodistal, 1.0);
  EXPECT_NEAR(crown.sizes().y(), p.buccolingual, 1.0);
  EXPECT_NEAR(crown.max().z(), p.crown_height, 1.0);
  EXPECT_NEAR(molar.bounds().min().z(), -p.root_length, 1.0);
  // Two roots (mesial and distal) or one: count the pieces a mesio-distal line meets halfway down.
  EXPECT_EQ(crossings_along_x(molar, 0.0137, -0.5 * p.root_length + 0.0111), 2 * p.roots);
  // Centred on the crown.
  EXPECT_NEAR(crown.center().x(), 0.0, 0.5);
  EXPECT_NEAR(crown.center().y(), 0.0, 0.5);
  // Edges about `resolution` long.
  EXPECT_GT(mean_edge(molar), 0.5 * p.resolution);
  EXPECT_LT(mean_edge(molar), 1.5 * p.resolution);
}

TEST_P(MolarShape, HasCuspsAroundALowerCentralFossa) {
  const MolarParams p = GetParam();
  const TriangleMesh molar = make_molar(p);
  const HeightGrid top = sample_top(molar, 0.4 * p.crown_height, 0.1);

  // One peak per cusp, each near a landmark cusp tip.
  const std::vector<Vec3> found = peaks(top, 1.2, 0.3);
  const ToothLandmarks marks = molar_landmarks(p);
  ASSERT_EQ(marks.cusp_tips.size(), static_cast<std::size_t>(p.cusps));
  EXPECT_EQ(found.size(), static_cast<std::size_t>(p.cusps));
  for (const auto& peak : found) {
    double nearest = 1e9;
    for (const auto& tip : marks.cusp_tips) nearest = std::min(nearest, (tip - peak).head<2>().norm());
    EXPECT_LT(nearest, 1.0) << "peak at " << peak.transpose() << " is far from every cusp tip";
  }
  double highest = -1e9;
  for (const auto& peak : found) highest = std::max(highest, peak.z());

  // The central region lies at least 1 mm below the cusp tips (and the landmark agrees with the mesh).
  double fossa = 1e9;
  for (int j = 0; j < top.ny; ++j) {
    for (int i = 0; i < top.nx; ++i) {
      const Vec3 q = top.point(i, j);
      if (!std::isnan(q.z()) && (q - marks.central_fossa).head<2>().norm() < 1.0)
        fossa = std::min(fossa, q.z());
    }
  }
  std::cout << "cusp tips up to " << highest << " mm, central fossa " << fossa << " mm\n";
  EXPECT_GE(highest - fossa, 1.0);
  EXPECT_LE(highest - fossa, 3.5);
  EXPECT_NEAR(marks.central_fossa.z(), fossa, 0.3);
  EXPECT_LT(marks.central_fossa.head<2>().norm(), 2.0);
}

INSTANTIATE_TEST_SUITE_P(Variants, MolarShape,
                         ::testing::Values(MolarParams{},
                                           MolarParams{11.0, 10.0, 7.5, 13.0, 4, 2, 0.2, false},
                                           MolarParams{10.5, 9.8, 7.0, 12.0, 4, 2, 0.2, true},
                                           MolarParams{11.5, 10.5, 7.5, 13.0, 5, 1, 0.25, false}));

TEST(Molar, FissuresAreNarrowGrooves) {
  // Across the central groove between the mesial cusps, the profile dips into a narrow V.
  const MolarParams p;
  const TriangleMesh molar = make_molar(p);
  const TopSurface top(molar, 0.4 * p.crown_height);
  const double x = 1.2;
  double y_low = 0.0;
  double z_low = 1e9;
  for (double y = -2.0; y <= 2.0; y += 0.02) {
    const double z = top.height(x, y);
    if (!std::isnan(z) && z < z_low) {
      z_low = z;
      y_low = y;
    }
  }
  const double beside = std::min(top.height(x, y_low - 0.5), top.height(x, y_low + 0.5));
  std::cout << "groove at y = " << y_low << ": " << (beside - z_low) << " mm deeper than 0.5 mm beside\n";
  EXPECT_GT(beside - z_low, 0.3);
  EXPECT_LT(beside - z_low, 1.5);
}

TEST(Molar, ProximalContactsFaceTheNeighbours) {
  const MolarParams p;
  const ToothLandmarks marks = molar_landmarks(p);
  EXPECT_NEAR(marks.mesial_contact.x(), 0.5 * p.mesiodistal, 0.5);
  EXPECT_NEAR(marks.distal_contact.x(), -0.5 * p.mesiodistal, 0.5);
  // Contacts sit in the occlusal half of the crown.
  EXPECT_GT(marks.mesial_contact.z(), 0.5 * p.crown_height);
  EXPECT_LT(marks.mesial_contact.z(), p.crown_height);
}

TEST(Molar, MirroredPutsBuccalAtMinusY) {
  MolarParams p;
  p.resolution = 0.25;
  const ToothLandmarks right = molar_landmarks(p);
  p.mirrored = true;
  const ToothLandmarks left = molar_landmarks(p);
  ASSERT_EQ(right.cusp_tips.size(), left.cusp_tips.size());
  for (std::size_t i = 0; i < right.cusp_tips.size(); ++i) {
    EXPECT_NEAR(left.cusp_tips[i].y(), -right.cusp_tips[i].y(), 1e-9);
    EXPECT_NEAR(left.cusp_tips[i].z(), right.cusp_tips[i].z(), 1e-6);
  }
  EXPECT_GT(right.cusp_tips[0].y(), 0.0);  // mesiobuccal
}

TEST(Molar, IsDeterministic) {
  MolarParams p;
  p.resolution = 0.3;
  const TriangleMesh a = make_molar(p);
  const TriangleMesh b = make_molar(p);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.triangles, b.triangles);
  for (std::size_t i = 0; i < a.vertices.size(); ++i) ASSERT_EQ(a.vertices[i], b.vertices[i]);
}

TEST(Molar, RejectsBadParameters) {
  MolarParams p;
  p.cusps = 3;
  EXPECT_THAT([&] { (void)make_molar(p); }, ::testing::ThrowsMessage<Error>(::testing::HasSubstr("cusps")));
  p = {};
  p.roots = 3;
  EXPECT_THAT([&] { (void)make_molar(p); }, ::testing::ThrowsMessage<Error>(::testing::HasSubstr("roots")));
  p = {};
  p.resolution = 0.0;
  EXPECT_THAT([&] { (void)make_molar(p); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("resolution")));
  p = {};
  p.mesiodistal = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)make_molar(p), Error);
}

TEST(Premolar, HasAHigherBuccalCuspAndOneRoot) {
  const PremolarParams p;
  const TriangleMesh premolar = make_premolar(p);
  expect_closed_and_clean(premolar, "premolar");
  const auto crown = crown_bounds(premolar);
  std::cout << "premolar " << premolar.triangles.size() << " triangles, crown " << crown.sizes().transpose()
            << " mm\n";
  EXPECT_NEAR(crown.sizes().x(), p.mesiodistal, 1.0);
  EXPECT_NEAR(crown.sizes().y(), p.buccolingual, 1.0);
  EXPECT_NEAR(crown.max().z(), p.crown_height, 1.0);
  EXPECT_NEAR(premolar.bounds().min().z(), -p.root_length, 1.0);

  // Two peaks: the buccal one (y > 0) higher than the lingual one (small: a narrower neighbourhood).
  const std::vector<Vec3> found = peaks(sample_top(premolar, 0.4 * p.crown_height, 0.1), 0.8, 0.3);
  ASSERT_EQ(found.size(), 2u);
  const Vec3& buccal = found[0].y() > found[1].y() ? found[0] : found[1];
  const Vec3& lingual = found[0].y() > found[1].y() ? found[1] : found[0];
  EXPECT_GT(buccal.y(), 0.0);
  EXPECT_LT(lingual.y(), 0.0);
  EXPECT_GT(buccal.z(), lingual.z() + 0.5);

  // One root: halfway down it, a mesio-distal line meets a single piece.
  EXPECT_EQ(crossings_along_x(premolar, 0.0137, -0.5 * p.root_length + 0.0111), 2);
  const ToothLandmarks marks = premolar_landmarks(p);
  ASSERT_EQ(marks.cusp_tips.size(), 2u);
  EXPECT_GT(marks.cusp_tips[0].z(), marks.cusp_tips[1].z());
}

}  // namespace
}  // namespace cariesim
