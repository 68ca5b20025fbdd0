// Angular grains (synth/angular_grains.hpp): the exact radial function of a known polyhedron,
// dents, the random draw (deterministic, centred, unit volume-equivalent radius, flat facets) and
// the grain set made with --grain-shape angular.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/angular_grains.hpp"
#include "graintwin/synth/grains.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/synth/packing.hpp"
#include "graintwin/synth/psd.hpp"
#include "graintwin/synth/render.hpp"

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

double volume_equivalent_radius(const shape::RadialTable& t) { return equivalent_radius(t.volume()); }

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
  EXPECT_NEAR(t.max_radius(), std::sqrt(3.0) / 2.0 * e, 1e-7 * e);  // corners are nodes (single precision)
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
    ASSERT_NEAR(ta.radius(nodes[k]), r, 2e-7 * r) << "node " << k;  // single precision, rounded again when scaled
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

// Contacts on sharp tables: the packer's kernel (pair_contact) measures radial depths and takes
// a table normal at its deepest point, which on a flat face pressed on a face, or an edge on a
// face, lies at a corner or an edge, where the table's normal is blended: it finds the contact,
// not its normal. The truth's re-measurement (separating_contact) gives the exact overlap and the
// face normal for both, and minus the gap when apart.
TEST(AngularContacts, TruthGivesTheExactOverlapAndNormalOfFacesAndEdges) {
  const double e = 1.0e-3, overlap = 0.01 * e, reach = 0.25 * e;
  const shape::RadialTable cube_table = cube(e).table(64);
  const double one_degree = std::cos(std::numbers::pi / 180.0);
  synth::PackedGrain a, b;
  b.position = Eigen::Vector3d(e - overlap, 0.2 * e, 0.1 * e);  // faces x = +e/2 of a and x = -e/2 of b overlap
  const auto face = synth::pair_contact(cube_table, a, cube_table, b, 0.1 * e);
  ASSERT_TRUE(face.has_value());
  const synth::PairContact face_truth = synth::separating_contact(cube_table, a, cube_table, b, *face, reach);
  EXPECT_NEAR(face_truth.overlap, overlap, 1e-3 * overlap);
  EXPECT_GT(face_truth.normal.x(), one_degree);
  // b turned 45 degrees about z: its edge (a node line of the table, so exact) points at a's face.
  b.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.25 * std::numbers::pi, Eigen::Vector3d::UnitZ()));
  b.position = Eigen::Vector3d(0.5 * e + std::sqrt(0.5) * e - overlap, 0.0, 0.0);
  const auto edge = synth::pair_contact(cube_table, a, cube_table, b, 0.1 * e);
  ASSERT_TRUE(edge.has_value());
  const synth::PairContact edge_truth = synth::separating_contact(cube_table, a, cube_table, b, *edge, reach);
  EXPECT_NEAR(edge_truth.overlap, overlap, 1e-3 * overlap);
  EXPECT_GT(edge_truth.normal.x(), one_degree);
  std::printf("[ contact ] face on face: kernel overlap %.3f of the true, normal %.1f deg off\n", face->overlap / overlap,
              std::acos(std::min(1.0, std::abs(face->normal.x()))) * 180.0 / std::numbers::pi);
  std::printf("[ contact ] edge on face: kernel overlap %.3f of the true, normal %.1f deg off; re-measured %.4f, "
              "%.2f deg off\n",
              edge->overlap / overlap, std::acos(std::min(1.0, std::abs(edge->normal.x()))) * 180.0 / std::numbers::pi,
              edge_truth.overlap / overlap, std::acos(std::min(1.0, edge_truth.normal.x())) * 180.0 / std::numbers::pi);
  // Apart by a gap: minus the gap, along the face normal.
  b.position.x() += 2.0 * overlap;
  const auto apart = synth::pair_contact(cube_table, a, cube_table, b, 0.1 * e);
  ASSERT_TRUE(apart.has_value());
  const synth::PairContact apart_truth = synth::separating_contact(cube_table, a, cube_table, b, *apart, reach);
  EXPECT_NEAR(apart_truth.overlap, -overlap, 1e-3 * overlap);
  EXPECT_GT(apart_truth.normal.x(), one_degree);
}

// Smooth bodies: for two spheres the re-measured contact is the exact one, to the table's
// sampling (its nodes lie on the sphere, so a support is short by at most r (1 - cos(cell / 2))).
TEST(AngularContacts, TruthOfTwoSpheresIsExact) {
  const double r = 1.0e-3, overlap = 0.01 * r;
  const shape::RadialTable ball = shape::RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, 64);
  synth::PackedGrain a, b;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  b.position = (2.0 * r - overlap) * axis;
  const auto first = synth::pair_contact(ball, a, ball, b, 0.1 * r);
  ASSERT_TRUE(first.has_value());
  const synth::PairContact truth = synth::separating_contact(ball, a, ball, b, *first, 0.25 * r);
  EXPECT_NEAR(truth.overlap, overlap, 2.0 * r * (1.0 - std::cos(1.0 / 63.0)));
  EXPECT_GT(truth.normal.dot(axis), std::cos(0.5 * std::numbers::pi / 180.0));
}

// true_contacts re-measures only when asked (ctsynth asks for angular grains): an edge pressed
// on a face keeps the kernel's overlap without it and gets the exact one with it.
TEST(AngularContacts, TrueContactsReMeasureOnlyWhenAsked) {
  const double e = 1.0e-3, overlap = 0.01 * e, tolerance = 0.02 * e;
  const shape::RadialTable cube_table = cube(e).table(64);
  synth::PackedGrain a, b;
  b.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.25 * std::numbers::pi, Eigen::Vector3d::UnitZ()));
  b.position = Eigen::Vector3d(0.5 * e + std::sqrt(0.5) * e - overlap, 0.0, 0.0);
  const auto kernel = synth::pair_contact(cube_table, a, cube_table, b, 0.1 * e);
  ASSERT_TRUE(kernel.has_value());
  const auto plain = synth::true_contacts({&cube_table, &cube_table}, {a, b}, 0.1 * e, tolerance);
  const auto remeasured = synth::true_contacts({&cube_table, &cube_table}, {a, b}, 0.1 * e, tolerance, true);
  ASSERT_EQ(plain.size(), 1u);
  ASSERT_EQ(remeasured.size(), 1u);
  EXPECT_EQ(plain[0].overlap, kernel->overlap);
  EXPECT_EQ(plain[0].normal, kernel->normal);
  EXPECT_NEAR(remeasured[0].overlap, overlap, 1e-3 * overlap);
  EXPECT_GT(remeasured[0].normal.x(), std::cos(std::numbers::pi / 180.0));
  EXPECT_TRUE(remeasured[0].touching);
}

// Rendering keeps sharp grains' volume: the analytic partial volumes (a secant plane per boundary
// voxel, split where the surface bends) of angular grains 16 voxels across, at random poses, sum
// to their table's volume within 0.1 % (measured: 0.023 % worst of 5), point samples within 1 %.
TEST(AngularRender, PartialVolumesSumToTheTableVolume) {
  const double voxel = 1e-5, r = 8e-5;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> jitter(0.0, voxel);
  double worst_analytic = 0.0;
  for (int i = 0; i < 5; ++i) {
    shape::RadialTable unit;
    synth::random_angular_grain(AngularShapeParams{}, rng, 96, &unit);
    const shape::RadialTable t = unit.scaled(r);
    const std::size_t side = static_cast<std::size_t>(std::ceil(2.0 * t.max_radius() / voxel)) + 4;
    const Eigen::Vector3d centre = Eigen::Vector3d::Constant(0.5 * side * voxel) +
                                   Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    const synth::PlacedGrain g{&t, centre, Eigen::Quaterniond::UnitRandom(), 1};
    for (int k : {0, 4}) {
      const synth::GrainImages im =
          synth::render_grains({g}, {side, side, side}, {voxel, voxel, voxel}, {0, 0, 0}, synth::RenderParams{k});
      double s = 0.0;
      for (float f : im.fraction.values()) s += f;
      const double err = s * voxel * voxel * voxel / t.volume() - 1.0;
      EXPECT_LT(std::abs(err), k == 0 ? 0.001 : 0.01) << "grain " << i << ", supersample " << k;
      if (k == 0) worst_analytic = std::max(worst_analytic, std::abs(err));
    }
  }
  std::printf("[ render ] angular grains, 16 voxels across: worst analytic volume error %.3f %%\n", 100 * worst_analytic);
}

// Angular grains pack in stages (the fit low-passed to degree 7 and 11, then the sharp tables):
// every pair's truth depth (the smaller of the kernel's and the separating one) and every wall
// depth is within the tolerance, and every grain touches something on average.
TEST(AngularPacking, SharpGrainsMeetTheToleranceInStages) {
  // About 20 grains of the default PSD; the cylinder (height = diameter) is sized to hold them at
  // solid fraction 0.45 exactly.
  std::mt19937_64 rng(12);
  const std::vector<double> diameters = synth::sample_diameters(synth::Psd{}, 0.45 * 2.65e-9, rng);
  synth::GrainSetParams gp;
  gp.shape = synth::GrainShape::angular;
  gp.seed = 12;
  const synth::GrainSet grains = synth::make_grains(gp, diameters);
  const auto shapes = grains.table_pointers();
  std::vector<std::vector<shape::RadialTable>> smooth;
  std::vector<std::vector<const shape::RadialTable*>> stages;
  for (int degree : {7, 11}) smooth.push_back(synth::smoothed_tables(grains, degree, gp.voxel_size));
  for (const auto& tables : smooth) {
    stages.emplace_back();
    for (const auto& t : tables) stages.back().push_back(&t);
  }
  stages.push_back(shapes);
  double volume = 0.0;
  for (const auto& st : grains.stats) volume += st.volume;
  synth::Container c;
  c.kind = synth::Container::Kind::cylinder;
  c.radius = std::cbrt(volume / (0.45 * 2.0 * std::numbers::pi));
  c.height = 2.0 * c.radius;
  synth::PackingParams p;
  p.seed = 3;
  p.contact_tolerance = 0.02;
  synth::PackingReport r;
  std::vector<synth::PackedGrain> packed;
  try {
    packed = synth::pack_in_stages(stages, c, p, &r);
  } catch (const Error& e) {
    FAIL() << e.message();
  }
  ASSERT_EQ(packed.size(), shapes.size());
  const double tol = r.tolerance;
  EXPECT_LE(r.max_overlap, tol);
  const auto contacts = synth::true_contacts(shapes, packed, tol, tol, true);
  std::size_t touching = 0;
  for (const auto& t : contacts) {
    EXPECT_LE(t.overlap, 1.01 * tol) << t.low << "-" << t.high;
    touching += t.touching;
  }
  for (std::size_t i = 0; i < packed.size(); ++i) EXPECT_LE(synth::wall_penetration(*shapes[i], packed[i], c), 1.01 * tol);
  EXPECT_GE(touching, packed.size());
  std::printf("[ packing ] %zu angular grains at %.2f: max overlap %.2f um (tolerance %.2f um), %zu touching, %d sweeps\n",
              packed.size(), r.solid_fraction, r.max_overlap * 1e6, tol * 1e6, touching, r.sweeps);
}
