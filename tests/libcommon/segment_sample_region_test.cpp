// Sample cylinder (fitted or given) and the void ratio inside it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/sample_region.hpp"
#include "support/golden.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

constexpr double kVoxel = 2e-5;
constexpr double kCx = 35.3, kCy = 34.6, kRadius = 28.0;  // voxels
const Vec3 kOrigin{1e-3, -2e-3, 5e-4};                      // z, y, x (m)

using test::Ball;

/// Random sequential addition of non-overlapping balls of radius r inside the cylinder (in voxels).
std::vector<Ball> fill_cylinder(Shape3 shape, double r, int attempts, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const auto u = [&](double lo, double hi) { return lo + (hi - lo) * (rng() % 100001) / 100000.0; };
  std::vector<Ball> balls;
  for (int a = 0; a < attempts; ++a) {
    const Ball b{u(r, shape[0] - 1 - r), u(kCy - kRadius, kCy + kRadius), u(kCx - kRadius, kCx + kRadius), r};
    if (std::hypot(b.x - kCx, b.y - kCy) > kRadius - r) continue;
    bool free = true;
    for (const Ball& o : balls) free = free && std::hypot(b.z - o.z, b.y - o.y, b.x - o.x) >= 2 * r;
    if (free) balls.push_back(b);
  }
  return balls;
}

Volume<std::uint8_t> paint(Shape3 shape, const std::vector<Ball>& balls) {
  return test::paint_balls(shape, balls, {kVoxel, kVoxel, kVoxel}, kOrigin);
}

Cylinder true_cylinder(const Volume<std::uint8_t>& m) {
  Cylinder c;
  const Vec3 p = m.position_xyz(0, kCy, kCx);
  c.centre_x = p[0], c.centre_y = p[1], c.radius = kRadius * kVoxel;
  return c;
}

}  // namespace

TEST(VoidRatio, KnownCylinderOfSpheres) {
  const Shape3 shape{40, 72, 72};
  const auto balls = fill_cylinder(shape, 4.5, 4000, 1);
  ASSERT_GT(balls.size(), 50u);
  const auto m = paint(shape, balls);
  const VoidRatio v = void_ratio(m, true_cylinder(m));
  // Analytic: cylinder pi R^2 H (H = 40 slices), spheres 4/3 pi r^3 each.
  const double solid = balls.size() * 4.0 / 3.0 * M_PI * std::pow(4.5 * kVoxel, 3);
  const double cylinder = M_PI * std::pow(kRadius * kVoxel, 2) * 40 * kVoxel;
  const double e = (cylinder - solid) / solid;
  EXPECT_NEAR(v.e / e, 1.0, 0.015);
  EXPECT_NEAR(v.solid_m3 / solid, 1.0, 0.015);
  EXPECT_NEAR((v.solid_m3 + v.void_m3) / cylinder, 1.0, 0.01);
  test::Golden measured("segment_sample_region");
  measured.check("spheres_void_ratio_over_exact", v.e / e);
  measured.check("spheres_solid_over_exact", v.solid_m3 / solid);
  measured.check("spheres_region_over_cylinder", (v.solid_m3 + v.void_m3) / cylinder);
  // The axial extent restricts the region: half the height, about half the volume.
  Cylinder half = true_cylinder(m);
  half.z_max = m.position_xyz(19.5, 0, 0)[2];
  const VoidRatio h = void_ratio(m, half);
  EXPECT_NEAR((h.solid_m3 + h.void_m3) / (v.solid_m3 + v.void_m3), 0.5, 1e-9);
}

TEST(VoidRatio, VolumetricStrainKeepsTheSolidVolume) {
  // Solid 1 m^3 with 0.8 m^3 of voids compacted to 0.6: V goes from 1.8 to 1.6 m^3.
  EXPECT_NEAR(void_ratio_volumetric_strain(0.8, 0.6), std::log(1.8 / 1.6), 1e-15);
  EXPECT_EQ(void_ratio_volumetric_strain(0.7, 0.7), 0.0);
  EXPECT_LT(void_ratio_volumetric_strain(0.6, 0.8), 0.0);  // dilation is negative
}

TEST(FitCylinder, FindsTheSampleAndIgnoresASolidMembrane) {
  const Shape3 shape{40, 72, 72};
  auto m = paint(shape, fill_cylinder(shape, 4.5, 6000, 2));
  const Cylinder fit = fit_sample_cylinder(m);
  const Cylinder truth = true_cylinder(m);
  EXPECT_NEAR(fit.centre_x, truth.centre_x, 1.0 * kVoxel);
  EXPECT_NEAR(fit.centre_y, truth.centre_y, 1.0 * kVoxel);
  EXPECT_NEAR(fit.radius, truth.radius, 2.5 * kVoxel);
  // A membrane shell 1.5 voxels thick hugging the outermost grains (rings 26 and 27, where the
  // grains' own occupancy has already fallen), classified as solid: its rings are solid in every
  // slice, and a fit that took them for sample would end beyond them, at 28 or more.
  const double inner = fit.radius / kVoxel;
  Volume<float> grey(shape, m.voxel_size(), m.origin());
  for (std::size_t z = 0; z < shape[0]; ++z)
    for (std::size_t y = 0; y < shape[1]; ++y)
      for (std::size_t x = 0; x < shape[2]; ++x) {
        const double r = std::hypot(x - kCx, y - kCy);
        const bool shell = r >= inner && r <= inner + 1.5;
        grey(z, y, x) = shell ? 0.4f : m(z, y, x) ? 0.75f : 0.25f;
        if (shell) m(z, y, x) = 1;
      }
  const Cylinder with_membrane = fit_sample_cylinder(m);
  EXPECT_NEAR(with_membrane.radius, fit.radius, 1.0 * kVoxel);
  EXPECT_LT(with_membrane.radius, (inner + 1.5) * kVoxel);
  const Cylinder with_band = fit_sample_cylinder(m, grey, GreyBand{0.35, 0.45});
  EXPECT_NEAR(with_band.radius, fit.radius, 1.0 * kVoxel);
  EXPECT_NEAR(with_band.centre_x, fit.centre_x, 0.5 * kVoxel);
}

TEST(FitCylinder, EndsWhereTheSampleEndsNotAtTheVolumesTop) {
  // A compressed sample leaves empty space under the top platen: grains fill slices 0-30 of 48.
  const Shape3 shape{48, 72, 72}, filled{31, 72, 72};
  const auto balls = fill_cylinder(filled, 4.5, 6000, 3);
  const auto m = paint(shape, balls);
  const Cylinder fit = fit_sample_cylinder(m);
  double top = 0;
  for (const Ball& b : balls) top = std::max(top, b.z + b.r);
  const double top_m = m.position_xyz(top, 0, 0)[2];
  EXPECT_NEAR(fit.z_max, top_m, 4.5 * kVoxel);
  // The void ratio of the sample, not of the sample plus the empty space above it (same circle).
  Cylinder sample = fit, whole = fit;
  sample.z_max = top_m;
  whole.z_min = -std::numeric_limits<double>::infinity();
  whole.z_max = std::numeric_limits<double>::infinity();
  const double e_sample = void_ratio(m, sample).e;
  EXPECT_NEAR(void_ratio(m, fit).e, e_sample, 0.05 * e_sample);
  EXPECT_GT(void_ratio(m, whole).e, 1.3 * e_sample);
}

TEST(FitCylinder, RefusesAnEmptyMaskAndBadInput) {
  Volume<std::uint8_t> empty({4, 5, 6});
  EXPECT_THROW(fit_sample_cylinder(empty), DataError);
  Cylinder c;
  c.radius = 1.0;
  EXPECT_THROW(void_ratio(empty, c), DataError);
  EXPECT_THROW(fit_sample_cylinder(empty, Volume<float>({1, 1, 1}), GreyBand{0, 1}), UsageError);
}
