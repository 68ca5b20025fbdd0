// Tests of the random sand-grain generator, the reference shapes and shape_stats (sand_shape.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace gs = graintwin::shape;

TEST(SandShape, SameSeedSameGrain) {
  const gs::SandShapeParams params;
  std::mt19937_64 a(17);
  std::mt19937_64 b(17);
  std::mt19937_64 c(18);
  const Eigen::VectorXd ga = gs::random_sand_coeffs(params, a);
  const Eigen::VectorXd gb = gs::random_sand_coeffs(params, b);
  const Eigen::VectorXd gc = gs::random_sand_coeffs(params, c);
  ASSERT_EQ(ga.size(), gs::sh_count(params.degree));
  EXPECT_EQ(ga, gb);
  EXPECT_GT((ga - gc).norm(), 1e-3);
}

// 200 default grains (degree 15, tables with n = 64): every grain has r > 0, centroid at the SH
// origin within 1e-4 (exact quadrature), volume-equivalent radius 1 within 1e-3 (table) and 1e-10
// (exact); the population's mean aspect ratio is in [1.2, 1.5] and mean sphericity in
// [0.85, 0.92] (Ottawa sand).
TEST(SandShape, OttawaPopulation) {
  const gs::SandShapeParams params;
  std::mt19937_64 rng(20240601);
  const int count = 200;
  double sum_ar = 0.0, sum_ar2 = 0.0, sum_sph = 0.0, sum_sph2 = 0.0;
  double min_radius = 1e300;
  for (int i = 0; i < count; ++i) {
    const Eigen::VectorXd c = gs::random_sand_coeffs(params, rng);
    const gs::ShMoments m = gs::sh_moments(c, params.degree);
    EXPECT_LT(m.centroid.norm(), 1e-4) << "grain " << i;
    EXPECT_NEAR(std::cbrt(3.0 * m.volume / (4.0 * std::numbers::pi)), 1.0, 1e-10) << "grain " << i;
    const gs::RadialTable table = gs::radial_table_from_sh(c, params.degree, 64);
    EXPECT_GT(table.min_radius(), 0.0) << "grain " << i;
    const gs::ShapeStats s = gs::shape_stats(table);
    EXPECT_NEAR(s.equivalent_diameter / 2.0, 1.0, 1e-3) << "grain " << i;
    sum_ar += s.aspect_ratio;
    sum_ar2 += s.aspect_ratio * s.aspect_ratio;
    sum_sph += s.sphericity;
    sum_sph2 += s.sphericity * s.sphericity;
    min_radius = std::min(min_radius, table.min_radius());
  }
  const double mean_ar = sum_ar / count;
  const double mean_sph = sum_sph / count;
  std::printf("200 grains: aspect ratio %.3f +- %.3f, sphericity %.4f +- %.4f, min r %.3f\n",
              mean_ar, std::sqrt(sum_ar2 / count - mean_ar * mean_ar), mean_sph,
              std::sqrt(sum_sph2 / count - mean_sph * mean_sph), min_radius);
  EXPECT_GE(mean_ar, 1.2);
  EXPECT_LE(mean_ar, 1.5);
  EXPECT_GE(mean_sph, 0.85);
  EXPECT_LE(mean_sph, 0.92);
}

// Degree 20 works: centred, unit volume-equivalent radius, positive.
TEST(SandShape, Degree20) {
  gs::SandShapeParams params;
  params.degree = 20;
  std::mt19937_64 rng(5);
  for (int i = 0; i < 5; ++i) {
    const Eigen::VectorXd c = gs::random_sand_coeffs(params, rng);
    ASSERT_EQ(c.size(), 441);
    const gs::ShMoments m = gs::sh_moments(c, 20);
    EXPECT_LT(m.centroid.norm(), 1e-4);
    EXPECT_NEAR(m.volume, 4.0 / 3.0 * std::numbers::pi, 1e-9);
    EXPECT_GT(m.min_sampled_radius, 0.1);
  }
}

// The spectrum follows the parameters: with no spread, Dhat_2 = d2, D_1 is only the small
// centring correction, and the power law holds for the degrees the re-fit barely touches.
TEST(SandShape, InvariantsFollowTheSpectrum) {
  gs::SandShapeParams params;
  params.d2_spread = 0.0;
  params.exponent_spread = 0.0;
  params.degree_jitter = 0.0;
  std::mt19937_64 rng(3);
  const Eigen::VectorXd c = gs::random_sand_coeffs(params, rng);
  const Eigen::VectorXd inv = gs::sh_invariants(c, params.degree);
  const double d2 = inv[2] / inv[0];
  EXPECT_NEAR(d2, params.d2, 0.05 * params.d2);
  EXPECT_LT(inv[1] / inv[0], 0.2 * params.d2);
  const double d5 = inv[5] / inv[0];
  EXPECT_NEAR(d5, params.d2 * std::pow(2.5, -params.roundness_exponent), 0.1 * d5);
  const double d12 = inv[12] / inv[0];
  const double expected12 = params.d2 * std::pow(4.0, -params.roundness_exponent) *
                            std::pow(12.0 / 8.0, -params.roughness_exponent);
  EXPECT_NEAR(d12, expected12, 0.1 * expected12);
}

// Grains drawn from one parameter set differ in the shape of their spectrum, not only in Dhat_2:
// the spread over 40 grains of log(Dhat_n / Dhat_2) is near 0 without the per-grain exponents and
// jitter (one drawn value sets every degree) and clearly positive with the defaults.
TEST(SandShape, SpectraVaryFromGrainToGrain) {
  const auto spread_of_spectrum_shape = [](const gs::SandShapeParams& params) {
    std::mt19937_64 rng(99);
    const int count = 40;
    Eigen::MatrixXd shape(count, params.degree - 2);  // log(Dhat_n / Dhat_2), n = 3..degree
    for (int i = 0; i < count; ++i) {
      const Eigen::VectorXd inv = gs::sh_invariants(gs::random_sand_coeffs(params, rng), params.degree);
      for (int n = 3; n <= params.degree; ++n) shape(i, n - 3) = std::log(inv[n] / inv[2]);
    }
    const Eigen::RowVectorXd mean = shape.colwise().mean();
    return std::sqrt((shape.rowwise() - mean).squaredNorm() / (count * shape.cols()));
  };
  gs::SandShapeParams fixed;
  fixed.exponent_spread = 0.0;
  fixed.degree_jitter = 0.0;
  const double without = spread_of_spectrum_shape(fixed);
  const double with = spread_of_spectrum_shape(gs::SandShapeParams{});
  std::printf("spread of log(Dhat_n / Dhat_2) over 40 grains: %.3f fixed law, %.3f default\n", without, with);
  EXPECT_LT(without, 0.06);
  EXPECT_GT(with, 0.15);
}

TEST(SandShape, RejectsBadParameters) {
  std::mt19937_64 rng(1);
  gs::SandShapeParams p;
  p.degree = 1;
  EXPECT_THROW(gs::random_sand_coeffs(p, rng), graintwin::UsageError);
  p = {};
  p.d2_spread = 1.0;
  EXPECT_THROW(gs::random_sand_coeffs(p, rng), graintwin::UsageError);
  p = {};
  p.roughness_from_degree = 17;
  EXPECT_THROW(gs::random_sand_coeffs(p, rng), graintwin::UsageError);
  p = {};
  p.exponent_spread = 1.0;
  EXPECT_THROW(gs::random_sand_coeffs(p, rng), graintwin::UsageError);
  p = {};
  p.degree_jitter = -0.1;
  EXPECT_THROW(gs::random_sand_coeffs(p, rng), graintwin::UsageError);
  EXPECT_THROW(gs::sphere_coeffs(-1.0), graintwin::UsageError);
  EXPECT_THROW(gs::ellipsoid_table(1.0, 0.0, 1.0), graintwin::UsageError);
  EXPECT_THROW(gs::shape_stats(gs::RadialTable()), graintwin::UsageError);
}

// Ellipsoid table (n = 64): volume 4/3 pi abc within 1e-3 relative; surface normal equal to the
// analytic normal (x/a^2, y/b^2, z/c^2) within 0.5 degree (measured 0.34 degree); shape_stats
// recovers the semi-axes within 1e-3 relative.
TEST(SandShape, EllipsoidTable) {
  const double a = 1.5e-3, b = 1.0e-3, c = 0.6e-3;
  const gs::RadialTable t = gs::ellipsoid_table(a, b, c, 64);
  EXPECT_NEAR(t.volume() / (4.0 / 3.0 * std::numbers::pi * a * b * c), 1.0, 1e-3);
  std::mt19937_64 rng(12);
  std::normal_distribution<double> normal;
  double worst_deg = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const double r = 1.0 / std::sqrt(d.x() * d.x() / (a * a) + d.y() * d.y() / (b * b) +
                                     d.z() * d.z() / (c * c));
    const Eigen::Vector3d p = r * d;
    const Eigen::Vector3d exact =
        Eigen::Vector3d(p.x() / (a * a), p.y() / (b * b), p.z() / (c * c)).normalized();
    const double cosine = std::min(1.0, exact.dot(t.surface_normal(d)));
    worst_deg = std::max(worst_deg, std::acos(cosine) * 180.0 / std::numbers::pi);
  }
  std::printf("ellipsoid n = 64: worst normal error %.3f degree\n", worst_deg);
  EXPECT_LT(worst_deg, 0.5);

  const gs::ShapeStats s = gs::shape_stats(t);
  EXPECT_NEAR(s.semi_axes[0] / a, 1.0, 1e-3);
  EXPECT_NEAR(s.semi_axes[1] / b, 1.0, 1e-3);
  EXPECT_NEAR(s.semi_axes[2] / c, 1.0, 1e-3);
  EXPECT_NEAR(s.aspect_ratio, a / c, 2e-3 * a / c);
  EXPECT_NEAR(s.equivalent_diameter, 2.0 * std::cbrt(a * b * c), 1e-3 * s.equivalent_diameter);
  EXPECT_LT(s.sphericity, 0.95);  // a 2.5:1.67:1 ellipsoid is clearly not a sphere
}

// A sphere: sphericity 1 and aspect ratio 1 within 1e-6.
TEST(SandShape, SphereStats) {
  const gs::RadialTable t = gs::radial_table_from_sh(gs::sphere_coeffs(2e-3), 0, 16);
  const gs::ShapeStats s = gs::shape_stats(t);
  EXPECT_NEAR(s.sphericity, 1.0, 1e-6);
  EXPECT_NEAR(s.aspect_ratio, 1.0, 1e-6);
  EXPECT_NEAR(s.equivalent_diameter, 4e-3, 1e-9);
  EXPECT_NEAR(s.semi_axes[1], 2e-3, 1e-9);
}
