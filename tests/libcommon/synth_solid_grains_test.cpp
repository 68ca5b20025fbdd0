// Grains that are not star-shaped (synth/solid_grains.hpp): a sphere with a pocket against its
// exact ray geometry and lens volume, the star hull, a voxel ball, pocketed angular grains and the
// grain set's share of them, their rendering, and true contacts on a pocket's lid.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/angular_grains.hpp"
#include "graintwin/synth/grains.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/synth/render.hpp"
#include "graintwin/synth/solid_grains.hpp"

using namespace graintwin;
using namespace graintwin::synth;

namespace {

constexpr double kPi = std::numbers::pi;

shape::RadialTable sphere_table(double r) {
  return shape::RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, 32);
}

// A unit sphere with a ball of radius rho removed, its centre at height h on the z axis (h > rho,
// h + rho > 1: it breaches the surface). Rays at polar angle theta cross the ball between
// t = h cos(theta) -+ sqrt(rho^2 - h^2 sin^2(theta)); where the far crossing is inside the sphere
// the ray re-enters (the lip), which gives the exact measures by a 1-D integral over theta.
struct PocketedSphere {
  double h = 0.75, rho = 0.4;
  NonStarMeasures exact() const {
    NonStarMeasures m;
    const int steps = 200000;
    const double theta_max = std::asin(rho / h);
    double solid_angle = 0.0, hidden = 0.0;
    for (int k = 0; k < steps; ++k) {
      const double th = (k + 0.5) / steps * theta_max;
      const double root = std::sqrt(rho * rho - h * h * std::sin(th) * std::sin(th));
      const double t0 = h * std::cos(th) - root, t1 = h * std::cos(th) + root;
      if (t1 >= 1.0) continue;
      const double d_omega = 2.0 * kPi * std::sin(th) * theta_max / steps;
      solid_angle += d_omega;
      hidden += (t1 * t1 * t1 - t0 * t0 * t0) / 3.0 * d_omega;
      m.reentry_depth = std::max(m.reentry_depth, 1.0 - t0);
    }
    m.multi_exit_fraction = solid_angle / (4.0 * kPi);
    m.hidden_void_fraction = hidden / volume();
    return m;
  }
  // The unit sphere less the lens it shares with the ball.
  double volume() const {
    const double R = 1.0, r = rho, d = h;
    const double lens = kPi * std::pow(R + r - d, 2) * (d * d + 2 * d * r - 3 * r * r + 2 * d * R + 6 * r * R - 3 * R * R) / (12 * d);
    return 4.0 / 3.0 * kPi - lens;
  }
  PocketedGrain solid() const { return PocketedGrain(sphere_table(1.0), {{Eigen::Vector3d(0, 0, h), rho}}); }
};

}  // namespace

TEST(SolidGrains, PocketedSphereMeasuresMatchTheExactRayGeometry) {
  const PocketedSphere ps;
  const PocketedGrain g = ps.solid();
  EXPECT_TRUE(g.contains(Eigen::Vector3d(0, 0, 0.2)));
  EXPECT_FALSE(g.contains(Eigen::Vector3d(0, 0, 0.75)));   // the pocket's centre
  EXPECT_TRUE(g.contains(Eigen::Vector3d(0.413, 0, 0.855)));  // under the lip, outside the pocket
  EXPECT_NEAR(g.level(Eigen::Vector3d(0.5, 0, -0.3)), 1.0 - std::hypot(0.5, 0.3), 1e-9);
  EXPECT_TRUE(g.may_differ_from_hull(Eigen::Vector3d(0, 0, 0.4), 0.01));
  EXPECT_FALSE(g.may_differ_from_hull(Eigen::Vector3d(0, 0, -0.5), 0.01));

  const NonStarMeasures exact = ps.exact();
  ASSERT_GT(exact.multi_exit_fraction, 0.005);
  const shape::ShapeStats stats = solid_stats(g, 0.01);
  EXPECT_NEAR(stats.volume / ps.volume(), 1.0, 0.003);
  const NonStarMeasures m = non_star_measures(g, ps.volume(), 0.005, 8192);
  EXPECT_NEAR(m.multi_exit_fraction / exact.multi_exit_fraction, 1.0, 0.08);
  EXPECT_NEAR(m.hidden_void_fraction / exact.hidden_void_fraction, 1.0, 0.08);
  EXPECT_NEAR(m.reentry_depth / exact.reentry_depth, 1.0, 0.02);
  // Along the axis the ray leaves at the pocket's floor and never comes back; beside the mouth it
  // leaves into the pocket and comes back under the lip.
  const RayExits axis = ray_exits(g, Eigen::Vector3d::UnitZ(), 0.005);
  EXPECT_NEAR(axis.first, ps.h - ps.rho, 1e-4);
  EXPECT_NEAR(axis.last, ps.h - ps.rho, 1e-4);
  const Eigen::Vector3d rim = Eigen::Vector3d(std::sin(0.45), 0, std::cos(0.45));
  const RayExits lip = ray_exits(g, rim, 0.005);
  EXPECT_LT(lip.first, 0.8);
  EXPECT_NEAR(lip.last, 1.0, 1e-3);
}

TEST(SolidGrains, DiscCavityLevelIsABoundOnTheDistance) {
  Pocket disc;
  disc.centre = Eigen::Vector3d(1, 0, 0);
  disc.radius = 0.5;
  disc.half_height = 0.1;
  disc.axis = Eigen::Vector3d(1, 1, 0).normalized();
  EXPECT_TRUE(disc.contains(Eigen::Vector3d(1, 0, 0.45)));    // in the disc's plane, inside its rim
  EXPECT_FALSE(disc.contains(Eigen::Vector3d(1.2, 0.2, 0)));  // along its axis, above its face
  EXPECT_NEAR(disc.outside_level(Eigen::Vector3d(1, 0, 0.9)), 0.4, 1e-12);
  EXPECT_NEAR(disc.bound(), std::hypot(0.5, 0.1), 1e-15);
  // Never more than the distance: sampled against the distance to points of the cylinder.
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d e1 = disc.axis.unitOrthogonal(), e2 = disc.axis.cross(e1);
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d p = disc.centre + Eigen::Vector3d(u(rng), u(rng), u(rng));
    double nearest = HUGE_VAL;
    for (double a = 0; a < 2 * kPi; a += 0.05)
      for (double r = 0; r <= 0.5; r += 0.01)
        for (double h = -0.1; h <= 0.1; h += 0.01)
          nearest = std::min(nearest, (p - disc.centre - h * disc.axis - r * (std::cos(a) * e1 + std::sin(a) * e2)).norm());
    if (!disc.contains(p)) {
      EXPECT_LE(disc.outside_level(p), nearest + 0.01) << p.transpose();
    }
  }
}

TEST(SolidGrains, StarShapedSolidsMissNothingAndTheHullHoldsTheSolid) {
  const PocketedGrain plain(sphere_table(1.0), {});
  const NonStarMeasures none = non_star_measures(plain, 4.0 / 3.0 * kPi, 0.01, 2048);
  EXPECT_EQ(none.multi_exit_fraction, 0.0);
  EXPECT_EQ(none.hidden_void_fraction, 0.0);
  EXPECT_EQ(none.reentry_depth, 0.0);

  const PocketedSphere ps;
  const PocketedGrain g = ps.solid();
  const shape::RadialTable hull = last_exit_table(g, 48, 0.005);
  EXPECT_NEAR(hull.radius(Eigen::Vector3d::UnitZ()), ps.h - ps.rho, 5e-3);  // the well down the mouth, ...
  EXPECT_NEAR(hull.radius(Eigen::Vector3d(std::sin(0.45), 0, std::cos(0.45))), 1.0, 1e-3);  // ... not over the lip
  EXPECT_NEAR(hull.radius(-Eigen::Vector3d::UnitZ()), 1.0, 1e-3);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int inside = 0;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    if (!g.contains(p)) continue;
    ++inside;
    EXPECT_LE(p.norm(), hull.radius(p) + 2e-3) << p.transpose();
  }
  EXPECT_GT(inside, 5000);
  EXPECT_THROW(ray_exits(PocketedGrain(sphere_table(1.0), {{Eigen::Vector3d::Zero(), 0.2}}), Eigen::Vector3d::UnitX(), 0.01),
               DataError);
}

TEST(SolidGrains, SmoothedVoxelBallIsStarShapedWithItsVolume) {
  const double voxel = 1e-5, r = 8.0;
  const std::size_t n = 26;
  const double centre = 0.5 * static_cast<double>(n - 1);
  Volume<float> field({n, n, n}, {voxel, voxel, voxel}, {-centre * voxel, -centre * voxel, -centre * voxel});
  for (std::size_t z = 0; z < n; ++z)
    for (std::size_t y = 0; y < n; ++y)
      for (std::size_t x = 0; x < n; ++x)
        field(z, y, x) = std::hypot(z - centre, y - centre, x - centre) <= r ? 1.0f : 0.0f;
  double voxels = 0.0;
  for (float v : field.values()) voxels += v;
  gaussian_blur(field, 0.7);
  // At level 0.5 the smoothing takes about 3 sigma^2 / r^2 of the volume; the volume-preserving level
  // gives it back.
  EXPECT_NEAR(solid_stats(VoxelGrain(field), 0.5 * voxel).volume / (voxels * voxel * voxel * voxel), 1.0 - 3 * 0.49 / (r * r), 0.01);
  const double iso = volume_preserving_level(field, voxels);
  EXPECT_LT(iso, 0.5);
  const VoxelGrain g(std::move(field), iso);
  EXPECT_TRUE(g.contains(Eigen::Vector3d::Zero()));
  EXPECT_FALSE(g.contains(Eigen::Vector3d(0, 0, 9.5 * voxel)));
  EXPECT_EQ(g.level(Eigen::Vector3d(1.0, 0, 0)), -iso);  // off the grid
  const shape::ShapeStats s = solid_stats(g, 0.25 * voxel);
  EXPECT_NEAR(s.volume / (voxels * voxel * voxel * voxel), 1.0, 0.003);
  EXPECT_NEAR(s.aspect_ratio, 1.0, 0.02);
  EXPECT_GT(s.sphericity, 0.97);
  EXPECT_EQ(non_star_measures(g, s.volume, 0.25 * voxel, 2048).multi_exit_fraction, 0.0);
}

TEST(SolidGrains, PocketedAngularGrainsAreCentredUnitAndNotStarShaped) {
  AngularShapeParams p;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    std::mt19937_64 rng(seed), again(seed);
    shape::RadialTable t;
    const AngularGrain g = random_angular_grain(p, rng, 48, &t, true);
    ASSERT_EQ(g.pockets.size(), 1u);
    EXPECT_EQ(random_angular_grain(p, again, 48, nullptr, true).pockets[0].centre, g.pockets[0].centre);
    const PocketedGrain solid(t, g.pockets);
    const shape::ShapeStats s = solid_stats(solid, 0.02);
    EXPECT_NEAR(s.equivalent_diameter, 2.0, 0.015) << "seed " << seed;
    EXPECT_GT(t.volume(), s.volume * 1.02);  // the cavity took a few percent
    EXPECT_GT(g.pockets[0].half_height, 0.0);  // an undercut: a flat cylinder
    // The centroid of the solid, from points on a grid.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double count = 0.0;
    for (double x = -2; x <= 2; x += 0.025)
      for (double y = -2; y <= 2; y += 0.025)
        for (double z = -2; z <= 2; z += 0.025)
          if (solid.contains({x, y, z})) sum += Eigen::Vector3d(x, y, z), count += 1.0;
    EXPECT_LT((sum / count).norm(), 0.01) << "seed " << seed;
    const NonStarMeasures m = non_star_measures(solid, s.volume, 0.01);
    EXPECT_GT(m.hidden_void_fraction, 0.0005) << "seed " << seed;
    EXPECT_GT(m.reentry_depth, 0.1) << "seed " << seed;
  }
  p.undercut_radius = 1.5;
  std::mt19937_64 rng(1);
  EXPECT_THROW(random_angular_grain(p, rng, 48, nullptr, true), UsageError);
}

TEST(SolidGrains, GrainSetDrawsTheStatedShareWithPocketsAndKeepsTheOthers) {
  GrainSetParams p;
  p.shape = GrainShape::angular;
  p.sand.degree = 8;
  p.voxel_size = 40e-6;
  const std::vector<double> diameters(12, 0.5e-3);
  const GrainSet plain = make_grains(p, diameters);
  p.non_star_share = 0.25;
  const GrainSet mixed = make_grains(p, diameters);
  ASSERT_EQ(mixed.solids.size(), 12u);
  int pocketed = 0;
  for (std::size_t i = 0; i < 12; ++i) {
    if (mixed.solids[i]) {
      ++pocketed;
      EXPECT_GT(mixed.non_star[i].hidden_void_fraction, 0.0) << i;
      EXPECT_NEAR(mixed.stats[i].equivalent_diameter / 0.5e-3, 1.0, 0.01) << i;
      EXPECT_LT(mixed.stats[i].volume, mixed.tables[i].volume());
    } else {
      EXPECT_EQ(mixed.non_star[i].multi_exit_fraction, 0.0);
      EXPECT_EQ(mixed.tables[i].radius(Eigen::Vector3d(0.3, -0.2, 0.9)), plain.tables[i].radius(Eigen::Vector3d(0.3, -0.2, 0.9)));
      EXPECT_EQ(mixed.coeffs_body.row(static_cast<Eigen::Index>(i)), plain.coeffs_body.row(static_cast<Eigen::Index>(i)));
    }
  }
  EXPECT_EQ(pocketed, 3);
  p.shape = GrainShape::sand;
  EXPECT_THROW(make_grains(p, diameters), UsageError);
}

TEST(SolidGrains, RenderedPocketHoldsTheSolidsVolumeAndNoLabel) {
  const double voxel = 1e-5, radius = 10 * voxel;
  const PocketedGrain g(sphere_table(radius), {{Eigen::Vector3d(0, 0, 0.75 * radius), 0.4 * radius}});
  const shape::RadialTable hull = sphere_table(radius);
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 0.5).normalized()));
  const std::vector<PlacedGrain> placed{{&hull, Eigen::Vector3d(15 * voxel, 15 * voxel, 15 * voxel), turn, 1, &g}};
  const GrainImages im = render_grains(placed, {30, 30, 30}, {voxel, voxel, voxel}, {0.5 * voxel, 0.5 * voxel, 0.5 * voxel}, {});
  double sum = 0.0;
  for (float f : im.fraction.values()) sum += f;
  const double exact = PocketedSphere{}.volume() * std::pow(radius / voxel, 3);
  EXPECT_NEAR(sum / exact, 1.0, 0.005);
  // The pocket's centre, turned with the grain, is void and unlabelled.
  const Eigen::Vector3d c = Eigen::Vector3d(15 * voxel, 15 * voxel, 15 * voxel) + turn * Eigen::Vector3d(0, 0, 0.75 * radius);
  const auto idx = [&](double w) { return static_cast<std::size_t>(std::lround(w / voxel - 0.5)); };
  EXPECT_EQ(im.labels(idx(c.z()), idx(c.y()), idx(c.x())), 0u);
  EXPECT_LT(im.fraction(idx(c.z()), idx(c.y()), idx(c.x())), 0.01f);
  EXPECT_EQ(im.labels(15, 15, 15), 1u);
}

TEST(SolidGrains, ContactOnAPocketsLidIsNotAContact) {
  // Grain 1: a unit sphere with a pocket under its +x pole; grain 2 touches the pole from outside.
  const shape::RadialTable big = sphere_table(1.0), small = sphere_table(0.3);
  const PocketedGrain pocketed(big, {{Eigen::Vector3d(0.75, 0, 0), 0.4}});
  const std::vector<const shape::RadialTable*> shapes{&big, &small};
  std::vector<PackedGrain> poses(2);
  poses[1].position = Eigen::Vector3d(1.3, 0, 0);
  const auto hull_contacts = true_contacts(shapes, poses, 0.05, 0.01);
  ASSERT_EQ(hull_contacts.size(), 1u);
  EXPECT_TRUE(hull_contacts[0].touching);
  EXPECT_TRUE(true_contacts(shapes, poses, 0.05, 0.01, false, {&pocketed, nullptr}).empty());
  // Touching beside the mouth, on the lip, it is one.
  poses[1].position = 1.3 * Eigen::Vector3d(0, 1, 0);
  EXPECT_EQ(true_contacts(shapes, poses, 0.05, 0.01, false, {&pocketed, nullptr}).size(), 1u);
  EXPECT_THROW(true_contacts(shapes, poses, 0.05, 0.01, false, {&pocketed}), UsageError);
}
