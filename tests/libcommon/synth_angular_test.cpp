// Angular grains (synth/angular_grains.hpp): the exact radial function of a known polyhedron,
// dents, the random draw (deterministic, centred, unit volume-equivalent radius, flat facets) and
// the grain set made with --grain-shape angular.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/angular_grains.hpp"
#include "graintwin/synth/grains.hpp"

using namespace graintwin;
using graintwin::synth::AngularGrain;
using graintwin::synth::AngularShapeParams;

namespace {

AngularGrain cube(double edge) {
  AngularGrain g;
  for (int a = 0; a < 3; ++a) {
    for (double s : {-1.0, 1.0}) {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[a] = s;
      g.normals.push_back(n);
      g.offsets.push_back(0.5 * edge);
    }
  }
  return g;
}

double volume_equivalent_radius(const shape::RadialTable& t) {
  return std::cbrt(3.0 * t.volume() / (4.0 * std::numbers::pi));
}

}  // namespace

TEST(AngularGrain, CubeRadiusIsExactAlongFaceNormalsEdgesAndDiagonals) {
  const double e = 2.0e-3;
  const AngularGrain g = cube(e);
  EXPECT_DOUBLE_EQ(g.radius(Eigen::Vector3d::UnitX()), 0.5 * e);
  EXPECT_DOUBLE_EQ(g.radius(-Eigen::Vector3d::UnitZ()), 0.5 * e);
  EXPECT_NEAR(g.radius(Eigen::Vector3d(1, 1, 1).normalized()), std::sqrt(3.0) / 2.0 * e, 1e-15);
  EXPECT_NEAR(g.radius(Eigen::Vector3d(1, 0, -1).normalized()), std::sqrt(2.0) / 2.0 * e, 1e-15);
  // A direction inside the +y face: the ray meets y = e/2.
  const Eigen::Vector3d u = Eigen::Vector3d(0.2, 1.0, -0.3).normalized();
  EXPECT_NEAR(g.radius(u) * u.y(), 0.5 * e, 1e-15);
  EXPECT_EQ(g.facet_of(u), 3);  // normals in order -x, +x, -y, +y, -z, +z
  EXPECT_EQ(g.visible_facets(shape::fibonacci_directions(500)), 6);
  EXPECT_DOUBLE_EQ(g.modulation(u), 1.0);
  // Its table holds the cube: volume e^3 and the centroid at the origin, to the table's accuracy
  // (the bilinear interpolant rounds the edges by a fraction of a cell).
  const shape::RadialTable t = g.table(96);
  EXPECT_NEAR(t.volume(), e * e * e, 2e-3 * e * e * e);
  EXPECT_LT(t.centroid().norm(), 1e-6 * e);
  EXPECT_NEAR(t.max_radius(), std::sqrt(3.0) / 2.0 * e, 1e-12 * e);  // corners are nodes
}

TEST(AngularGrain, HalfSpacesFacingAwayLeaveADirectionUnbounded) {
  AngularGrain g;
  g.normals = {Eigen::Vector3d::UnitZ()};
  g.offsets = {1.0};
  EXPECT_TRUE(std::isinf(g.polyhedron_radius(-Eigen::Vector3d::UnitZ())));
  EXPECT_EQ(g.facet_of(-Eigen::Vector3d::UnitZ()), -1);
  EXPECT_DOUBLE_EQ(g.polyhedron_radius(Eigen::Vector3d::UnitZ()), 1.0);
}

TEST(AngularGrain, DentIsDeepestOnItsAxisAndEndsAtItsWidth) {
  AngularGrain g = cube(2.0);
  g.dents.push_back({Eigen::Vector3d::UnitX(), 0.1, 0.4});
  EXPECT_NEAR(g.radius(Eigen::Vector3d::UnitX()), 0.9, 1e-15);
  // Half-way out (angle 0.2): 1 - 0.1 (1 - 0.25)^2.
  const Eigen::Vector3d half(std::cos(0.2), std::sin(0.2), 0.0);
  EXPECT_NEAR(g.modulation(half), 1.0 - 0.1 * 0.75 * 0.75, 1e-12);
  const Eigen::Vector3d outside(std::cos(0.41), 0.0, std::sin(0.41));
  EXPECT_DOUBLE_EQ(g.modulation(outside), 1.0);
  // The dent is a local concavity: the mid-point of two surface points across it lies outside.
  const Eigen::Vector3d a = Eigen::Vector3d(std::cos(0.3), std::sin(0.3), 0.0);
  const Eigen::Vector3d b = Eigen::Vector3d(std::cos(0.3), -std::sin(0.3), 0.0);
  const Eigen::Vector3d mid = 0.5 * (g.radius(a) * a + g.radius(b) * b);
  EXPECT_GT(mid.norm(), g.radius(mid.normalized()));
}

TEST(AngularGrain, MovingTheOriginAndScalingAreExact) {
  AngularGrain g = cube(2.0);
  g.move_origin(Eigen::Vector3d(0.25, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(g.radius(Eigen::Vector3d::UnitX()), 0.75);
  EXPECT_DOUBLE_EQ(g.radius(-Eigen::Vector3d::UnitX()), 1.25);
  g.scale(2.0);
  EXPECT_DOUBLE_EQ(g.radius(Eigen::Vector3d::UnitX()), 1.5);
  EXPECT_THROW(g.move_origin(Eigen::Vector3d(2.0, 0.0, 0.0)), DataError);
  EXPECT_THROW(g.scale(0.0), UsageError);
}

TEST(RandomAngularGrain, SameSeedSameGrainCentredAtUnitSize) {
  const AngularShapeParams p;
  std::mt19937_64 a(5), b(5), c(6);
  shape::RadialTable ta, tb;
  const AngularGrain ga = synth::random_angular_grain(p, a, 64, &ta);
  const AngularGrain gb = synth::random_angular_grain(p, b, 64, &tb);
  const AngularGrain gc = synth::random_angular_grain(p, c, 64);
  EXPECT_EQ(ga.offsets, gb.offsets);
  EXPECT_EQ(ga.roughness, gb.roughness);
  EXPECT_NE(ga.offsets, gc.offsets);
  EXPECT_EQ(ta.volume(), tb.volume());
  EXPECT_LT(ta.centroid().norm(), 1e-6);
  EXPECT_NEAR(volume_equivalent_radius(ta), 1.0, 1e-12);
  // The table is the exact radius sampled: at every face node they agree (the ghost ring beyond a
  // face's edge is read through the neighbouring face, so it is skipped).
  const int n = 64;
  const std::vector<Eigen::Vector3d> nodes = shape::RadialTable::node_directions(n);
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const int i = static_cast<int>(k % (n + 2)), j = static_cast<int>(k / (n + 2) % (n + 2));
    if (i == 0 || j == 0 || i == n + 1 || j == n + 1) continue;
    const double r = ga.radius(nodes[k]);
    ASSERT_NEAR(ta.radius(nodes[k]), r, 1e-9 * r) << "node " << k;
  }
}

TEST(RandomAngularGrain, FacetsAreFlatInTheTable) {
  // No dents, no roughness: points of the table well inside one facet lie on its plane.
  AngularShapeParams p;
  p.max_dents = 0;
  p.roughness = 0.0;
  std::mt19937_64 rng(21);
  shape::RadialTable t;
  const AngularGrain g = synth::random_angular_grain(p, rng, 96, &t);
  const std::vector<Eigen::Vector3d> dirs = shape::fibonacci_directions(20000);
  const int visible = g.visible_facets(dirs);
  EXPECT_GE(visible, p.min_facets - 4);  // a drawn plane may lie wholly outside
  std::vector<int> on_facet(g.normals.size(), 0);
  double worst = 0.0;
  for (const auto& u : dirs) {
    const int f = g.facet_of(u);
    // Interior: the facet's plane also bounds the neighbours 0.03 rad away.
    const Eigen::Vector3d t1 = u.unitOrthogonal(), t2 = u.cross(t1);
    bool interior = true;
    for (const Eigen::Vector3d& w : {t1, Eigen::Vector3d(-t1), t2, Eigen::Vector3d(-t2)}) interior = interior && g.facet_of((u + 0.03 * w).normalized()) == f;
    if (!interior) continue;
    ++on_facet[static_cast<std::size_t>(f)];
    const Eigen::Vector3d x = t.radius(u) * u;
    worst = std::max(worst, std::abs(g.normals[static_cast<std::size_t>(f)].dot(x) - g.offsets[static_cast<std::size_t>(f)]));
  }
  EXPECT_LT(worst, 4e-4);  // of the volume-equivalent radius (1): the bilinear interpolant of a plane in cube-face coordinates
  EXPECT_GE(*std::max_element(on_facet.begin(), on_facet.end()), 200);
}

TEST(RandomAngularGrain, InvalidParametersAreUsageErrors) {
  std::mt19937_64 rng(1);
  AngularShapeParams p;
  p.min_facets = 3;
  EXPECT_THROW(synth::random_angular_grain(p, rng, 32), UsageError);
  p = {};
  p.max_facets = 6;
  p.min_facets = 7;
  EXPECT_THROW(synth::random_angular_grain(p, rng, 32), UsageError);
  p = {};
  p.dent_depth = 0.5;
  EXPECT_THROW(synth::random_angular_grain(p, rng, 32), UsageError);
  p = {};
  p.roughness = 0.2;
  EXPECT_THROW(synth::random_angular_grain(p, rng, 32), UsageError);
  p = {};
  p.roughness_degree = 100;
  EXPECT_THROW(synth::random_angular_grain(p, rng, 32), UsageError);
}

TEST(MakeGrains, AngularGrainsHaveTheirDrawnSizeAndAnSHFit) {
  synth::GrainSetParams gp;
  gp.shape = synth::GrainShape::angular;
  gp.sand.degree = 15;
  gp.seed = 4;
  const std::vector<double> d{0.4e-3, 0.55e-3, 0.8e-3};
  const synth::GrainSet a = synth::make_grains(gp, d);
  const synth::GrainSet b = synth::make_grains(gp, d);
  ASSERT_EQ(a.tables.size(), 3u);
  ASSERT_EQ(a.sh_fit_rms.size(), 3u);
  EXPECT_EQ(a.coeffs_body, b.coeffs_body);
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(a.stats[i].equivalent_diameter, d[i], 1e-9 * d[i]);
    EXPECT_LT(a.tables[i].centroid().norm(), 1e-6 * d[i]);
    EXPECT_GT(a.tables[i].min_radius(), 0.0);
    // A sharp-edged body is not band-limited: the degree-15 fit misses by a little, not by much.
    EXPECT_GT(a.sh_fit_rms[i], 1e-4);
    EXPECT_LT(a.sh_fit_rms[i], 0.05);
    // The fit's mean radius is the body's: c_00 / sqrt(4 pi) within 2 % of the equivalent radius.
    EXPECT_NEAR(a.coeffs_body(static_cast<Eigen::Index>(i), 0) / std::sqrt(4.0 * std::numbers::pi), 0.5 * d[i],
                0.02 * d[i]);
    EXPECT_LT(a.stats[i].sphericity, 0.95);  // angular: clearly below a sphere's 1
  }
  // The packing's smooth stand-ins come from the fit and are valid tables.
  const auto smooth = synth::smoothed_tables(a, 7, gp.voxel_size);
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_GT(smooth[i].min_radius(), 0.0);
    EXPECT_NEAR(volume_equivalent_radius(smooth[i]), 0.5 * d[i], 0.03 * d[i]);
  }
  EXPECT_EQ(synth::parse_grain_shape("angular"), synth::GrainShape::angular);
  EXPECT_THROW(synth::parse_grain_shape("crushed"), UsageError);
}
