// Dense packing of star-shaped grains (synth/packing): pair geometry against analytic answers,
// packings of spheres and 1.3:1 ellipsoids with an Ottawa-sand size spread, determinism, and the
// refusals. Sphere packings are checked with exact sphere geometry, independent of the kernels.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/packing.hpp"

using namespace graintwin;
using graintwin::shape::RadialTable;
using graintwin::synth::Container;
using graintwin::synth::PackedGrain;

namespace {

constexpr double kDeg = M_PI / 180.0;

RadialTable sphere(double r, int n = 16) {
  return RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, n);
}

// Ellipsoid with semi-axes (a, b, c) along the body axes.
double ellipsoid_radius(const Eigen::Vector3d& u, double a, double b, double c) {
  return 1.0 / std::sqrt(u.x() * u.x() / (a * a) + u.y() * u.y() / (b * b) + u.z() * u.z() / (c * c));
}
RadialTable ellipsoid(double a, double b, double c, int n = 64) {
  return RadialTable::from_function(
      [=](const Eigen::Vector3d& u) { return ellipsoid_radius(u, a, b, c); }, n);
}

Eigen::Quaterniond random_quaternion(std::mt19937_64& rng) {
  std::normal_distribution<double> nd;
  Eigen::Quaterniond q(nd(rng), nd(rng), nd(rng), nd(rng));
  q.normalize();
  return q;
}

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Grains drawn from the Ottawa-sand size spread of the reference experiment (docs/methods.md): equivalent diameters 0.30 to
// 1.03 mm, log-normal with sigma 0.25 and a volume-weighted d50 of 0.551 mm (number median
// ln d50 - 3 sigma^2). Diameters are binned into 40 classes that share one table each.
struct GrainSet {
  std::vector<std::unique_ptr<RadialTable>> tables;
  std::vector<const RadialTable*> shapes;
  std::vector<double> radius;  // equivalent radius of each grain
  double volume = 0.0;
};

GrainSet ottawa_grains(int count, double aspect, std::uint64_t seed = 42) {
  const int bins = 40;
  const double dmin = 0.30e-3, dmax = 1.03e-3, sigma = 0.25;
  const double mu = std::log(0.551e-3) - 3.0 * sigma * sigma;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(mu, sigma);
  GrainSet g;
  g.tables.resize(bins);
  for (int i = 0; i < count; ++i) {
    double d;
    do {
      d = std::exp(nd(rng));
    } while (d < dmin || d > dmax);
    const int b = std::min(bins - 1, static_cast<int>(std::log(d / dmin) / std::log(dmax / dmin) * bins));
    const double db = dmin * std::pow(dmax / dmin, (b + 0.5) / bins);
    if (!g.tables[b]) {
      // Prolate ellipsoid a : b : b = aspect : 1 : 1 with the volume of a sphere of diameter db.
      const double k = 0.5 * db / std::cbrt(aspect);
      g.tables[b] = std::make_unique<RadialTable>(
          aspect == 1.0 ? sphere(0.5 * db) : ellipsoid(aspect * k, k, k, 32));
    }
    g.shapes.push_back(g.tables[b].get());
    g.radius.push_back(0.5 * db);
    g.volume += g.tables[b]->volume();
  }
  return g;
}

// Cylinder with height = diameter holding `volume` at solid fraction `fill`.
Container cylinder_for(double volume, double fill) {
  Container c;
  c.kind = Container::Kind::cylinder;
  c.radius = std::cbrt(volume / fill / (2.0 * M_PI));
  c.height = 2.0 * c.radius;
  return c;
}

Container cube_for(double volume, double fill) {
  Container c;
  c.kind = Container::Kind::box;
  const double edge = std::cbrt(volume / fill);
  c.box_size = {edge, edge, edge};
  return c;
}

// Largest pair overlap from pair_contact over all pairs whose bounding spheres meet (O(N^2)
// bounding test: fine for a few hundred grains), and the number of touching pairs.
void pair_check(const GrainSet& g, const std::vector<PackedGrain>& p, double tol, double& max_ov,
                std::size_t& touching) {
  max_ov = -HUGE_VAL;
  touching = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double reach = g.shapes[i]->max_radius() + g.shapes[j]->max_radius() + tol;
      if ((p[i].position - p[j].position).norm() > reach) continue;
      const auto pc = synth::pair_contact(*g.shapes[i], p[i], *g.shapes[j], p[j], tol);
      if (!pc) continue;
      max_ov = std::max(max_ov, pc->overlap);
      if (std::abs(pc->overlap) <= tol) ++touching;
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pair geometry

TEST(Container, KindsAreNamedAndParsedByOneTable) {
  for (auto kind : {synth::Container::Kind::cylinder, synth::Container::Kind::box})
    EXPECT_EQ(synth::parse_container_kind(synth::container_kind_name(kind)), kind);
  try {
    synth::parse_container_kind("sphere");
    FAIL() << "sphere parsed";
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--container 'sphere' is not cylinder or box");
  }
}

TEST(PairContact, TwoSpheresGiveTheExactOverlapNormalAndPoint) {
  const double ra = 0.3e-3, rb = 0.2e-3;
  const RadialTable a = sphere(ra), b = sphere(rb);
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    PackedGrain ga, gb;
    ga.position = Eigen::Vector3d(1e-3, -2e-3, 0.5e-3);
    ga.orientation = random_quaternion(rng);
    gb.orientation = random_quaternion(rng);
    const Eigen::Vector3d n = random_quaternion(rng) * Eigen::Vector3d::UnitX();
    const double overlap = trial % 2 ? 4e-6 : -3e-6;  // overlap, then gap
    gb.position = ga.position + (ra + rb - overlap) * n;
    const auto pc = synth::pair_contact(a, ga, b, gb, 10e-6);
    ASSERT_TRUE(pc.has_value());
    EXPECT_NEAR(pc->overlap, overlap, 1e-9);  // 0.001 um
    EXPECT_LT(angle_between(pc->normal, n), 0.01 * kDeg);
    const Eigen::Vector3d mid = ga.position + (ra - 0.5 * overlap) * n;
    EXPECT_LT((pc->point - mid).norm(), 0.05e-6);
    // Swapping the grains flips the normal only.
    const auto back = synth::pair_contact(b, gb, a, ga, 10e-6);
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(back->overlap, overlap, 1e-9);
    EXPECT_LT(angle_between(back->normal, -n), 0.01 * kDeg);
  }
}

// The ground-truth contacts of rough sand grains are symmetric: seen from either grain, the same
// depth and point and opposite unit normals, for pairs overlapping or a few um apart.
TEST(PairContact, SandGrainContactsAreSymmetricWithUnitNormals) {
  std::mt19937_64 rng(8);
  const int degree = 15;
  const RadialTable a = graintwin::shape::radial_table_from_sh(
      0.25e-3 * graintwin::shape::random_sand_coeffs({}, rng), degree, 96);
  const RadialTable b = graintwin::shape::radial_table_from_sh(
      0.2e-3 * graintwin::shape::random_sand_coeffs({}, rng), degree, 96);
  for (int trial = 0; trial < 12; ++trial) {
    PackedGrain ga, gb;
    ga.orientation = random_quaternion(rng);
    gb.orientation = random_quaternion(rng);
    const Eigen::Vector3d dir = random_quaternion(rng) * Eigen::Vector3d::UnitX();
    // Bring b in along dir until the pair is within 2 um, then on to an overlap on odd trials.
    const double wanted = trial % 2 ? 2e-6 : -2e-6;
    std::optional<synth::PairContact> ab;
    for (double dist = a.max_radius() + b.max_radius(); dist > 0.0; dist -= 0.5e-6) {
      gb.position = ga.position + dist * dir;
      ab = synth::pair_contact(a, ga, b, gb, 3e-6);
      if (ab && ab->overlap >= wanted) break;
    }
    ASSERT_TRUE(ab.has_value());
    const auto ba = synth::pair_contact(b, gb, a, ga, 3e-6);
    ASSERT_TRUE(ba.has_value());
    EXPECT_NEAR(ab->normal.norm(), 1.0, 1e-12);
    EXPECT_NEAR(ba->normal.norm(), 1.0, 1e-12);
    EXPECT_NEAR(ab->overlap, ba->overlap, 0.02e-6) << "trial " << trial;
    EXPECT_LT(angle_between(ab->normal, -ba->normal), 0.5 * kDeg) << "trial " << trial;
    EXPECT_LT((ab->point - ba->point).norm(), 0.2e-6) << "trial " << trial;
  }
}

TEST(PairContact, SeparatedBeyondTheSearchGapIsNothing) {
  const RadialTable a = sphere(0.3e-3), b = sphere(0.2e-3);
  PackedGrain ga, gb;
  gb.position = {0.5e-3 + 20e-6, 0.0, 0.0};  // 20 um apart
  EXPECT_FALSE(synth::pair_contact(a, ga, b, gb, 10e-6).has_value());
  const auto pc = synth::pair_contact(a, ga, b, gb, 30e-6);
  ASSERT_TRUE(pc.has_value());
  EXPECT_NEAR(pc->overlap, -20e-6, 1e-9);
}

TEST(PairContact, SphereOnEllipsoidNormalMatchesTheAnalyticNormal) {
  // Ellipsoid (a) with semi-axes 0.40, 0.30, 0.25 mm; a 0.2 mm sphere (b) pressed 1 um into it at
  // random surface points, centred on the ellipsoid's normal there, so the exact contact normal is
  // the ellipsoid's normal and the exact depth 1 um.
  const double ea = 0.40e-3, eb = 0.30e-3, ec = 0.25e-3, rs = 0.2e-3, depth = 1e-6;
  const RadialTable ell = ellipsoid(ea, eb, ec, 128), sph = sphere(rs);
  std::mt19937_64 rng(11);
  double worst_angle = 0.0, worst_depth = 0.0;
  for (int trial = 0; trial < 40; ++trial) {
    PackedGrain ge, gs;
    ge.position = {0.2e-3, 0.1e-3, -0.3e-3};
    ge.orientation = random_quaternion(rng);
    const Eigen::Vector3d u = random_quaternion(rng) * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d p_body = ellipsoid_radius(u, ea, eb, ec) * u;
    const Eigen::Vector3d n_body =
        Eigen::Vector3d(p_body.x() / (ea * ea), p_body.y() / (eb * eb), p_body.z() / (ec * ec))
            .normalized();
    const Eigen::Vector3d n = ge.orientation * n_body;
    gs.position = ge.position + ge.orientation * p_body + (rs - depth) * n;
    gs.orientation = random_quaternion(rng);
    const auto ab = synth::pair_contact(ell, ge, sph, gs, 5e-6);
    const auto ba = synth::pair_contact(sph, gs, ell, ge, 5e-6);
    ASSERT_TRUE(ab && ba);
    worst_angle = std::max({worst_angle, angle_between(ab->normal, n), angle_between(ba->normal, -n)});
    worst_depth = std::max({worst_depth, std::abs(ab->overlap - depth), std::abs(ba->overlap - depth)});
  }
  EXPECT_LT(worst_angle, 0.5 * kDeg);
  EXPECT_LT(worst_depth, 0.05e-6);  // 5 % of the depth: the 128-node table's own error is ~0.01 um
}

TEST(PairContact, MovingApartByTheOverlapAlongTheNormalLeavesTwoEllipsoidsTouching) {
  // Self-consistency of depth and normal for two 1.3:1 ellipsoids in random orientations: the
  // overlap is the translation along the normal that separates them.
  const RadialTable a = ellipsoid(0.39e-3, 0.3e-3, 0.3e-3), b = ellipsoid(0.26e-3, 0.2e-3, 0.2e-3);
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    PackedGrain ga, gb;
    ga.orientation = random_quaternion(rng);
    gb.orientation = random_quaternion(rng);
    const Eigen::Vector3d dir = random_quaternion(rng) * Eigen::Vector3d::UnitX();
    // Bring b in along dir until it overlaps by a few um.
    double dist = 0.7e-3;  // beyond the largest reach, 0.39 + 0.26 mm
    std::optional<synth::PairContact> pc;
    for (int k = 0; k < 300; ++k, dist -= 1e-6) {
      gb.position = ga.position + dist * dir;
      pc = synth::pair_contact(a, ga, b, gb, 1e-6);
      if (pc && pc->overlap > 3e-6) break;
    }
    ASSERT_TRUE(pc && pc->overlap > 3e-6);
    gb.position += pc->overlap * pc->normal;
    const auto after = synth::pair_contact(a, ga, b, gb, 1e-6);
    ASSERT_TRUE(after.has_value());
    EXPECT_LT(std::abs(after->overlap), 0.05e-6) << "trial " << trial << ", overlap was " << pc->overlap;
  }
}

TEST(WallPenetration, MatchesTheSupportFunctionOfAnEllipsoid) {
  const double ea = 0.4e-3, eb = 0.3e-3, ec = 0.25e-3;
  const RadialTable ell = ellipsoid(ea, eb, ec, 128);
  Container box;
  box.kind = Container::Kind::box;
  box.box_size = {2e-3, 3e-3, 4e-3};
  std::mt19937_64 rng(9);
  for (int trial = 0; trial < 10; ++trial) {
    PackedGrain g;
    g.orientation = random_quaternion(rng);
    g.position = {0.35e-3, 1.5e-3, 2.0e-3};  // near the x = 0 wall only
    const Eigen::Matrix3d R = g.orientation.toRotationMatrix();
    const Eigen::Matrix3d A = R * Eigen::Vector3d(ea * ea, eb * eb, ec * ec).asDiagonal() * R.transpose();
    const double support_x = std::sqrt(A(0, 0));  // half-width of the ellipsoid along x
    EXPECT_NEAR(synth::wall_penetration(ell, g, box), support_x - g.position.x(), 0.05e-6);
  }
}

// ---------------------------------------------------------------------------------------------
// Packings

TEST(PackGrains, ThreeHundredSpheresPackDenselyWithinTheTolerance) {
  const GrainSet g = ottawa_grains(300, 1.0);
  // 0.565 over the whole cylinder: with ~6 grains across, the loose layer at the walls makes 300
  // spheres jam near 0.58 over the container (measured: 0.575 packs, 0.60 jams); the core, a d50
  // away from the walls, is what must reach random-dense values.
  const Container c = cylinder_for(g.volume, 0.565);
  synth::PackingParams p;
  synth::PackingReport r;
  std::vector<synth::PackingStatus> statuses;
  const auto packed =
      synth::pack_grains(g.shapes, c, p, &r, [&](const synth::PackingStatus& s) { statuses.push_back(s); });
  ASSERT_EQ(packed.size(), 300u);
  EXPECT_NEAR(r.solid_fraction, 0.565, 1e-9);
  EXPECT_GE(r.core_solid_fraction, 0.60);
  const double tol = r.tolerance;
  EXPECT_NEAR(tol, 0.005 * *std::min_element(g.radius.begin(), g.radius.end()), 1e-3 * tol);
  EXPECT_LE(r.max_overlap, tol);
  EXPECT_LE(r.max_wall_overlap, tol);
  // Exact sphere geometry, independent of the contact kernels.
  double max_ov = 0.0, max_wall = -HUGE_VAL;
  std::size_t touching = 0;
  for (std::size_t i = 0; i < packed.size(); ++i) {
    const Eigen::Vector3d& x = packed[i].position;
    const double ri = g.radius[i];
    max_wall = std::max({max_wall, std::hypot(x.x(), x.y()) + ri - c.radius, ri - x.z(),
                         x.z() + ri - c.height});
    for (std::size_t j = i + 1; j < packed.size(); ++j) {
      const double ov = ri + g.radius[j] - (x - packed[j].position).norm();
      max_ov = std::max(max_ov, ov);
      if (std::abs(ov) <= tol) ++touching;
    }
  }
  EXPECT_LE(max_ov, tol * (1.0 + 1e-6));
  EXPECT_LE(max_wall, tol * (1.0 + 1e-6));  // every grain inside the container
  EXPECT_EQ(touching, r.touching_pairs);
  // The ground-truth contact list finds the same pairs, each within the tolerance.
  const auto contacts = synth::find_contacts(g.shapes, packed, tol);
  EXPECT_EQ(contacts.size(), touching);
  for (const auto& k : contacts) {
    ASSERT_LT(k.a, k.b);
    const Eigen::Vector3d branch = packed[k.b].position - packed[k.a].position;
    EXPECT_NEAR(k.contact.overlap, g.radius[k.a] + g.radius[k.b] - branch.norm(), 1e-9);
    EXPECT_LT(angle_between(k.contact.normal, branch), 0.05 * kDeg);
  }
  EXPECT_GE(r.touching_pairs, 600u);  // about 2 contacts per grain or more: a jammed-like packing
  // Status: every sweep but the last (which ends the packing) reports, growing to full size and
  // then settling toward the tolerance.
  ASSERT_EQ(statuses.size(), static_cast<std::size_t>(r.sweeps - 1));
  for (std::size_t k = 0; k < statuses.size(); ++k) ASSERT_EQ(statuses[k].sweep, static_cast<int>(k + 1));
  EXPECT_LT(statuses.front().scale, 1.0);
  EXPECT_EQ(statuses.back().scale, 1.0);
  EXPECT_EQ(statuses.back().tolerance, tol);
  EXPECT_EQ(statuses.back().max_sweeps, p.max_sweeps);
  EXPECT_EQ(statuses.back().stages, 1u);
  std::printf("[ packing ] 300 spheres: solid fraction %.3f (core %.3f), max overlap %.3f um "
              "(tolerance %.3f um), %zu touching pairs, %d sweeps, %.2f s\n",
              r.solid_fraction, r.core_solid_fraction, r.max_overlap * 1e6, tol * 1e6,
              r.touching_pairs, r.sweeps, r.seconds);
}

TEST(PackingStatus, ReadsAsAStatusLine) {
  EXPECT_EQ(synth::packing_status_text({0, 3, 812, 20000, 0.9315, 12.3e-6, 5.5e-6}),
            "stage 1 of 3, sweep 812 of at most 20000: growing, 93.1 % of full size, deepest overlap 12.30 um");
  EXPECT_EQ(synth::packing_status_text({1, 3, 2, 20000, 0.9996, 52.3e-6, 5.5e-6}),
            "stage 2 of 3, sweep 2 of at most 20000: growing, 99.9 % of full size, deepest overlap 52.30 um");
  EXPECT_EQ(synth::packing_status_text({0, 1, 4000, 20000, 1.0, 12.3e-6, 5.5e-6}),
            "sweep 4000 of at most 20000: at full size, deepest overlap 12.30 um, to end within 5.50 um");
}

TEST(PackGrains, ThreeHundredEllipsoidsReachSixtyPercent) {
  const GrainSet g = ottawa_grains(300, 1.3);
  const Container c = cube_for(g.volume, 0.60);
  synth::PackingParams p;
  p.seed = 7;
  synth::PackingReport r;
  const auto packed = synth::pack_grains(g.shapes, c, p, &r);
  ASSERT_EQ(packed.size(), 300u);
  EXPECT_GE(r.solid_fraction, 0.58);
  EXPECT_GE(r.core_solid_fraction, 0.62);
  const double tol = r.tolerance;
  EXPECT_LE(r.max_overlap, tol);
  double max_ov;
  std::size_t touching;
  pair_check(g, packed, tol, max_ov, touching);
  EXPECT_LE(max_ov, tol * 1.01);
  EXPECT_GE(touching, 600u);
  // Inside the box (wall_penetration is checked against the exact support function above).
  double max_wall = -HUGE_VAL;
  for (std::size_t i = 0; i < packed.size(); ++i) {
    max_wall = std::max(max_wall, synth::wall_penetration(*g.shapes[i], packed[i], c));
  }
  EXPECT_LE(max_wall, tol * 1.01);
  std::printf("[ packing ] 300 ellipsoids 1.3:1: solid fraction %.3f (core %.3f), max overlap "
              "%.3f um (tolerance %.3f um), %zu touching pairs, %d sweeps, %.2f s\n",
              r.solid_fraction, r.core_solid_fraction, r.max_overlap * 1e6, tol * 1e6,
              r.touching_pairs, r.sweeps, r.seconds);
}

TEST(PackGrains, SameSeedGivesIdenticalGrainsForAnyThreadCount) {
  // 400 grains: enough candidate pairs (~1900) for the pair loop to run in parallel.
  const GrainSet g = ottawa_grains(400, 1.3, 8);
  const Container c = cylinder_for(g.volume, 0.50);
  synth::PackingParams p;
  p.seed = 12345;
  const int threads = omp_get_max_threads();
  const auto first = synth::pack_grains(g.shapes, c, p);
  const auto again = synth::pack_grains(g.shapes, c, p);
  omp_set_num_threads(threads == 1 ? 2 : 1);
  const auto other_threads = synth::pack_grains(g.shapes, c, p);
  omp_set_num_threads(threads);
  p.seed = 54321;
  const auto other_seed = synth::pack_grains(g.shapes, c, p);
  ASSERT_EQ(first.size(), 400u);
  bool seed_differs = false;
  for (std::size_t i = 0; i < first.size(); ++i) {
    for (const auto* run : {&again, &other_threads}) {
      EXPECT_EQ(first[i].position, (*run)[i].position) << "grain " << i;
      EXPECT_EQ(first[i].orientation.coeffs(), (*run)[i].orientation.coeffs()) << "grain " << i;
    }
    seed_differs = seed_differs || first[i].position != other_seed[i].position;
  }
  EXPECT_TRUE(seed_differs);
}

TEST(PackGrains, OverfullSceneIsRefusedWithTheLimit) {
  const GrainSet g = ottawa_grains(50, 1.0);
  const Container c = cylinder_for(g.volume, 0.78);
  try {
    synth::pack_grains(g.shapes, c, synth::PackingParams{});
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("0.78"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("0.74"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("cylinder"), std::string::npos) << e.message();
  }
}

TEST(PackGrains, SceneAboveJammingIsRefused) {
  // 0.70 is below 0.74 but far above what random spheres jam at: the growth stalls.
  const GrainSet g = ottawa_grains(60, 1.0);
  const Container c = cube_for(g.volume, 0.70);
  try {
    synth::pack_grains(g.shapes, c, synth::PackingParams{});
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("jam"), std::string::npos) << e.message();
  }
}

TEST(PackGrains, BadInputIsAUsageError) {
  const RadialTable s = sphere(0.3e-3);
  Container c;
  c.radius = 2e-3;
  c.height = 4e-3;
  EXPECT_THROW(synth::pack_grains({&s, nullptr}, c, {}), UsageError);
  Container flat = c;
  flat.height = 0.0;
  EXPECT_THROW(synth::pack_grains({&s}, flat, {}), UsageError);
  synth::PackingParams bad;
  bad.contact_tolerance = 0.0;
  EXPECT_THROW(synth::pack_grains({&s}, c, bad), UsageError);
  // A grain wider than the container is a DataError with the sizes.
  Container thin = c;
  thin.radius = 0.2e-3;
  EXPECT_THROW(synth::pack_grains({&s}, thin, {}), DataError);
  // No grains: nothing to do.
  synth::PackingReport r;
  EXPECT_TRUE(synth::pack_grains({}, c, {}, &r).empty());
}

TEST(RelaxGrains, RemovesTheOverlapsOfACompressedPacking) {
  const GrainSet g = ottawa_grains(200, 1.0, 3);
  const Container c = cylinder_for(g.volume, 0.45);
  synth::PackingReport r0;
  std::vector<PackedGrain> poses = synth::pack_grains(g.shapes, c, {}, &r0);
  // A relaxed state passes in one sweep, untouched.
  std::vector<PackedGrain> same = poses;
  const synth::PackingReport r1 = synth::relax_grains(g.shapes, same, c, {});
  EXPECT_EQ(r1.sweeps, 1);
  for (std::size_t i = 0; i < poses.size(); ++i) EXPECT_EQ(same[i].position, poses[i].position);
  // Compress by 4 % (affine in z, container height likewise): overlaps appear, then go.
  Container lower = c;
  lower.height *= 0.96;
  for (auto& p : poses) p.position.z() *= 0.96;
  const std::vector<PackedGrain> start = poses;
  const synth::PackingReport r2 = synth::relax_grains(g.shapes, poses, lower, {});
  EXPECT_GT(r2.sweeps, 1);
  EXPECT_NEAR(r2.solid_fraction, 0.45 / 0.96, 1e-9);
  const double tol = r2.tolerance;
  double max_ov = 0.0, max_wall = -HUGE_VAL;
  std::vector<double> moves;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3d& x = poses[i].position;
    const double ri = g.radius[i];
    max_wall = std::max({max_wall, std::hypot(x.x(), x.y()) + ri - lower.radius, ri - x.z(),
                         x.z() + ri - lower.height});
    for (std::size_t j = i + 1; j < poses.size(); ++j) {
      max_ov = std::max(max_ov, ri + g.radius[j] - (x - poses[j].position).norm());
    }
    moves.push_back((x - start[i].position).norm());
  }
  EXPECT_LE(max_ov, tol * (1.0 + 1e-6));
  EXPECT_LE(max_wall, tol * (1.0 + 1e-6));
  // A local adjustment (the compression made overlaps of ~20 um), not a new packing.
  std::sort(moves.begin(), moves.end());
  EXPECT_LT(moves[moves.size() / 2], 50e-6);
  EXPECT_LT(moves.back(), 0.3e-3);
  // Mismatched input is a usage error.
  poses.pop_back();
  EXPECT_THROW(synth::relax_grains(g.shapes, poses, lower, {}), UsageError);
}

TEST(CoreSolidFraction, SimpleCubicSpheresFillPiOverSix) {
  const double d = 1e-3;
  const RadialTable s = sphere(0.5 * d);
  std::vector<const RadialTable*> shapes;
  std::vector<PackedGrain> grains;
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 4; ++i) {
        PackedGrain g;
        g.position = d * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        grains.push_back(g);
        shapes.push_back(&s);
      }
    }
  }
  Container box;
  box.kind = Container::Kind::box;
  box.box_size = {4 * d, 4 * d, 4 * d};
  EXPECT_NEAR(synth::core_solid_fraction(shapes, grains, box, 0.0), M_PI / 6.0, 0.01);
  EXPECT_NEAR(synth::core_solid_fraction(shapes, grains, box, d), M_PI / 6.0, 0.01);
  EXPECT_TRUE(std::isnan(synth::core_solid_fraction(shapes, grains, box, 2.5 * d)));
}
