// micro/: local deformation (D2min, affine tensor, local strain) against exact affine and
// single-grain motions; histograms; power-law fits on samples drawn from known laws; clusters and
// radii of gyration; g(r) of a lattice and of an ideal gas in a cylinder; coordination numbers;
// force statistics, grain stress q, volatility and Pearson's r with its p-value; simulation frames
// read as states (grain table checks, grain-grain contacts and their normal forces) and the strong
// network.
#include <gtest/gtest.h>
#include <omp.h>
#include <gsl/gsl_sf_zeta.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>

#include "graintwin/micro/clusters.hpp"
#include "graintwin/micro/distributions.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/micro/forces.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "graintwin/micro/local_deformation.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/micro/structure.hpp"
#include "support/run_tool.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using namespace graintwin::micro;

namespace {

/// A simple cubic lattice of n^3 points with spacing a, corner at the origin.
std::vector<Eigen::Vector3d> cubic_lattice(int n, double a) {
  std::vector<Eigen::Vector3d> p;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) p.emplace_back(a * x, a * y, a * z);
  return p;
}

std::size_t index_of(int n, int x, int y, int z) { return std::size_t((z * n + y) * n + x); }

}  // namespace

TEST(LocalDeformation, PureAffineMotionHasNoD2minAndTheAppliedStrain) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 5e-3);
  std::vector<Eigen::Vector3d> before(2000), after(2000);
  Eigen::Matrix3d f;  // symmetric stretch, compression positive strain = I - F
  f << 1.0 - 0.01, 0.004, -0.002,  //
      0.004, 1.0 + 0.015, 0.003,   //
      -0.002, 0.003, 1.0 - 0.03;
  const Eigen::Vector3d shift(1e-4, -2e-4, 3e-4);
  for (std::size_t i = 0; i < before.size(); ++i) {
    for (int k = 0; k < 3; ++k) before[i][k] = u(rng);
    after[i] = f * before[i] + shift;
  }
  DeformationOptions o;
  o.d50 = 0.5e-3;
  o.radius = 1.5 * o.d50;
  const auto r = local_deformation(before, after, o);
  std::size_t ok = 0;
  for (const auto& g : r) {
    if (g.status != DeformationStatus::ok) continue;
    ++ok;
    EXPECT_LT(g.d2min, 1e-20);
    EXPECT_LT((g.lambda - f).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::Matrix<double, 6, 1> want = (Eigen::Matrix<double, 6, 1>() << 0.01, -0.015, 0.03, -0.003, 0.002, -0.004).finished();
    EXPECT_LT((g.strain - want).cwiseAbs().maxCoeff(), 1e-12);
    // e_dev of diag(0.01, -0.015, 0.03) with mean 25/3e-3, plus the shear terms twice.
    const double m = (0.01 - 0.015 + 0.03) / 3.0;
    const double dd = std::pow(0.01 - m, 2) + std::pow(-0.015 - m, 2) + std::pow(0.03 - m, 2) +
                      2.0 * (0.003 * 0.003 + 0.002 * 0.002 + 0.004 * 0.004);
    EXPECT_NEAR(g.eps_q, std::sqrt(2.0 / 3.0 * dd), 1e-12);
  }
  EXPECT_GT(ok, 1900u);  // a few grains at the corners may have too few neighbours
}

TEST(LocalDeformation, OneDisplacedGrainGivesTheAnalyticD2min) {
  // Simple cubic lattice with spacing a = d50; radius 1.5 a takes the 6 face and 12 edge neighbours
  // (Y = 10 a^2 I, sum of mu = 0). Grain m moves by delta, nothing else moves. Then
  //   m itself:            D2min = |delta|^2 (1 - s^T Y^-1 s / N) = |delta|^2            (s = 0)
  //   a neighbour k of m:  D2min = |delta|^2 (1 - mu_m^T Y^-1 mu_m) / N
  //     face (|mu| = a): (1 - 0.1) / 18;  edge (|mu| = a sqrt 2): (1 - 0.2) / 18.
  const int n = 7;
  const double a = 0.5e-3;
  auto before = cubic_lattice(n, a);
  auto after = before;
  const std::size_t m = index_of(n, 3, 3, 3);
  const Eigen::Vector3d delta(0.1 * a, -0.05 * a, 0.02 * a);
  after[m] += delta;
  DeformationOptions o;
  o.d50 = a;
  o.radius = 1.5 * a;
  const auto r = local_deformation(before, after, o);
  const double d2 = delta.squaredNorm() / (a * a);
  ASSERT_EQ(r[m].status, DeformationStatus::ok);
  EXPECT_EQ(r[m].neighbours, 18u);
  EXPECT_NEAR(r[m].d2min, d2, 1e-12 * d2);
  EXPECT_NEAR(r[index_of(n, 4, 3, 3)].d2min, d2 * 0.9 / 18.0, 1e-12 * d2);
  EXPECT_NEAR(r[index_of(n, 3, 2, 3)].d2min, d2 * 0.9 / 18.0, 1e-12 * d2);
  EXPECT_NEAR(r[index_of(n, 4, 4, 3)].d2min, d2 * 0.8 / 18.0, 1e-12 * d2);
  // Corner neighbours (a sqrt 3 > 1.5 a) do not see m.
  EXPECT_LT(r[index_of(n, 4, 4, 4)].d2min, 1e-24);
}

TEST(LocalDeformation, TrackedStrainsOfAnAffineMapAreExact) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  const std::size_t n = 40, t = 3;
  std::vector<double> c(n * t * 3);
  const auto stretch = [](std::size_t s) { return Eigen::Vector3d(1.0 + 0.01 * double(s), 1.0, 1.0 - 0.03 * double(s)); };
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    for (std::size_t s = 0; s < t; ++s) {
      const Eigen::Vector3d q = stretch(s).asDiagonal() * p + Eigen::Vector3d(1e-4 * double(s), 0, 0);
      for (int k = 0; k < 3; ++k) c[3 * (i * t + s) + k] = (i == 7 && s == 2) ? std::nan("") : q[k];
    }
  }
  const auto eps = tracked_strains(c, n, t);
  for (std::size_t s = 0; s < t; ++s) {
    EXPECT_NEAR(eps.axial[s], -std::log(stretch(s).z()), 1e-12);
    EXPECT_NEAR(eps.volumetric[s], -std::log(stretch(s).prod()), 1e-12);
  }
}

TEST(LocalDeformation, DegenerateNeighbourhoodsAreFlaggedNotGarbage) {
  const double a = 0.5e-3;
  // A flat layer: every neighbourhood is coplanar, so Y is singular.
  std::vector<Eigen::Vector3d> flat;
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) flat.emplace_back(a * x, a * y, 0.0);
  // One grain far away from everything: too few neighbours. One grain missing from the second state.
  flat.emplace_back(1.0, 1.0, 1.0);
  auto after = flat;
  after[0] = Eigen::Vector3d::Constant(std::nan(""));
  DeformationOptions o;
  o.d50 = a;
  o.radius = 1.5 * a;
  const auto r = local_deformation(flat, after, o);
  EXPECT_EQ(r[0].status, DeformationStatus::missing);
  for (std::size_t i = 1; i < 25; ++i) {
    EXPECT_EQ(r[i].status, DeformationStatus::singular) << i;
    EXPECT_TRUE(std::isnan(r[i].d2min) && std::isnan(r[i].eps_q) && r[i].strain.hasNaN());
  }
  EXPECT_EQ(r[25].status, DeformationStatus::too_few_neighbours);
  EXPECT_EQ(r[25].neighbours, 0u);
  // The missing grain is nobody's neighbour: grain 1 (at x = a) keeps 3 + 2 - 1 neighbours.
  EXPECT_EQ(r[1].neighbours, 4u);
}

TEST(Distributions, HistogramsAreDensities) {
  std::vector<double> v;
  for (int i = 1; i <= 1000; ++i) v.push_back((i - 0.5) * 1e-3);  // none on a bin edge
  v.push_back(std::nan(""));
  const Histogram lin = linear_histogram(v, 0.0, 1.0, 10);
  EXPECT_EQ(lin.used, 1000u);
  for (auto c : lin.count) EXPECT_EQ(c, 100u);
  EXPECT_NEAR(lin.density[3], 1.0, 1e-12);
  const Histogram lg = log_histogram(v, 1e-3, 1.0, 5);
  ASSERT_EQ(lg.count.size(), 15u);
  double integral = 0.0;
  for (std::size_t b = 0; b < lg.count.size(); ++b) integral += lg.density[b] * (lg.edges[b + 1] - lg.edges[b]);
  EXPECT_NEAR(integral, 1.0, 1e-12);
  EXPECT_EQ(lg.used, 999u);  // 0.0005 is below the first bin
  EXPECT_EQ(lg.outside, 1u);
  const Histogram a = log_histogram_auto({0.02, 0.5, 3.0}, 4);
  EXPECT_LE(a.edges.front(), 0.02);
  EXPECT_GE(a.edges.back(), 3.0);
  EXPECT_EQ(a.used, 3u);
}

TEST(Distributions, ContinuousPowerLawRecoversExponentAndXmin) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double alpha = 2.5, x_min = 5.0;
  std::vector<double> v;
  for (int i = 0; i < 4000; ++i) v.push_back(x_min * std::pow(1.0 - u(rng), -1.0 / (alpha - 1.0)));
  for (int i = 0; i < 1500; ++i) v.push_back(1.0 + 4.0 * u(rng));  // not a power law below x_min
  const PowerLawFit f = fit_power_law(v, false);
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.alpha, alpha, 3.0 * f.alpha_error) << f.alpha << " +- " << f.alpha_error;
  EXPECT_LT(f.alpha_error, 0.05);
  EXPECT_GT(f.x_min, 4.5);
  EXPECT_LT(f.x_min, 7.0);
  // A fixed x_min reproduces the closed form.
  const PowerLawFit g = fit_power_law_continuous({1.0, 2.0, 4.0}, 1.0);
  EXPECT_NEAR(g.alpha, 1.0 + 3.0 / (std::log(2.0) + std::log(4.0)), 1e-12);
}

TEST(Distributions, DiscretePowerLawRecoversExponent) {
  // Exact discrete draws by inverting P(S >= s) = zeta(alpha, s) / zeta(alpha, 1).
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double alpha = 2.2;
  const double z1 = gsl_sf_hzeta(alpha, 1.0);
  std::vector<double> v;
  for (int i = 0; i < 4000; ++i) {
    const double p = u(rng);
    double lo = 1.0, hi = 2.0;  // find the largest s with P(S >= s) >= 1 - p
    while (gsl_sf_hzeta(alpha, hi) / z1 >= 1.0 - p) lo = hi, hi *= 2.0;
    while (hi - lo > 1.0) {
      const double mid = std::floor(0.5 * (lo + hi));
      (gsl_sf_hzeta(alpha, mid) / z1 >= 1.0 - p ? lo : hi) = mid;
    }
    v.push_back(lo);
  }
  const PowerLawFit fixed = fit_power_law_discrete(v, 1.0);
  ASSERT_TRUE(fixed.valid);
  EXPECT_NEAR(fixed.alpha, alpha, 3.0 * fixed.alpha_error) << fixed.alpha << " +- " << fixed.alpha_error;
  EXPECT_LT(fixed.alpha_error, 0.03);
  const PowerLawFit best = fit_power_law(v, true);
  ASSERT_TRUE(best.valid);
  EXPECT_NEAR(best.alpha, alpha, 3.0 * best.alpha_error) << best.alpha << " +- " << best.alpha_error << " s_min " << best.x_min;
  EXPECT_LE(best.ks, fixed.ks);
}

TEST(Distributions, ExponentialAndLineFits) {
  std::mt19937_64 rng(3);
  std::exponential_distribution<double> e(1.0 / 0.7);
  std::vector<double> v;
  for (int i = 0; i < 20000; ++i) v.push_back(1.0 + e(rng));
  const ExponentialFit f = fit_exponential(v, 1.0);
  EXPECT_NEAR(f.scale, 0.7, 3.0 * f.scale_error);
  const LineFit l = fit_line({0.0, 1.0, 2.0, 3.0}, {1.0, 3.0, 5.0, 7.0});
  ASSERT_TRUE(l.valid);
  EXPECT_NEAR(l.slope, 2.0, 1e-12);
  EXPECT_NEAR(l.intercept, 1.0, 1e-12);
  EXPECT_NEAR(l.slope_error, 0.0, 1e-12);
  EXPECT_FALSE(fit_line({1.0, 1.0, 1.0}, {1.0, 2.0, 3.0}).valid);
}

TEST(Clusters, RadiusOfGyrationIsVolumeWeighted) {
  // Volumes V and 3V a distance L apart: R sits L/4 from the larger, R_g^2 = 3 L^2 / 16.
  const double l = 2e-3;
  EXPECT_NEAR(radius_of_gyration({{0, 0, 0}, {l, 0, 0}}, {1e-9, 3e-9}), l * std::sqrt(3.0) / 4.0, 1e-15);
  EXPECT_EQ(radius_of_gyration({{1, 2, 3}}, {1.0}), 0.0);
}

TEST(Clusters, TopGrainsJoinThroughContacts) {
  // A line of 40 touching spheres of radius r; the 4 highest scores are grains 10, 11, 12 (a chain)
  // and 30 (alone): two clusters, sizes 3 and 1.
  const double r = 0.25e-3;
  std::vector<Eigen::Vector3d> p;
  std::vector<double> vol, score;
  for (int i = 0; i < 40; ++i) {
    p.emplace_back(2.0 * r * i, 0.0, 0.0);
    vol.push_back(4.0 / 3.0 * std::numbers::pi * r * r * r);
    score.push_back(0.001 * i);
  }
  score[10] = 5.0, score[11] = 6.0, score[12] = 7.0, score[30] = 8.0;
  ClusterOptions o;
  const ClusterStatistics st = cluster_statistics(score, p, vol, o);
  EXPECT_EQ(st.selected, 4u);
  EXPECT_EQ(st.threshold, 5.0);
  ASSERT_EQ(st.size.size(), 2u);
  EXPECT_EQ(st.cluster[10], st.cluster[12]);
  EXPECT_NE(st.cluster[10], st.cluster[30]);
  EXPECT_EQ(st.cluster[0], -1);
  EXPECT_EQ(st.size[std::size_t(st.cluster[11])], 3u);
  EXPECT_NEAR(st.radius_of_gyration[std::size_t(st.cluster[11])], 2.0 * r * std::sqrt(2.0 / 3.0), 1e-15);
  EXPECT_EQ(top_fraction({1.0, std::nan(""), 3.0, 2.0}, 0.5), (std::vector<std::size_t>{2}));
  EXPECT_EQ(connected_components(5, {{0, 3}, {3, 4}}), (std::vector<std::uint32_t>{0, 1, 2, 0, 0}));
}

TEST(Structure, LatticePairCorrelationPeaksAtTheShellDistances) {
  const double a = 1e-3;
  const auto p = cubic_lattice(9, a);
  const Region box = enclosing_region(p, Region::Kind::box);
  const PairCorrelation g = pair_correlation(p, box, 2.1 * a, 70);
  // Non-zero bins are exactly the lattice shells a, sqrt2 a, sqrt3 a, 2a (each well inside one bin).
  std::vector<double> shells;
  for (std::size_t b = 0; b < g.g.size(); ++b)
    if (g.g[b] > 0.0) shells.push_back(g.r[b] / a);
  ASSERT_EQ(shells.size(), 4u);
  const double want[4] = {1.0, std::sqrt(2.0), std::sqrt(3.0), 2.0};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(shells[std::size_t(k)], want[k], 0.015) << k;
}

TEST(Structure, EdgeCorrectionMakesAnIdealGasFlatInACylinder) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> p;
  while (p.size() < 6000) {
    const Eigen::Vector3d q(u(rng), u(rng), u(rng));
    if (q.head<2>().norm() <= 1.0) p.push_back(q);
  }
  Region cyl;
  cyl.kind = Region::Kind::cylinder;
  cyl.lo = Eigen::Vector3d(0, 0, -1), cyl.hi = Eigen::Vector3d(0, 0, 1), cyl.radius = 1.0;
  const PairCorrelation g = pair_correlation(p, cyl, 0.6, 12);
  for (std::size_t b = 2; b < g.g.size(); ++b) EXPECT_NEAR(g.g[b], 1.0, 0.05) << "r = " << g.r[b];
  EXPECT_NEAR(cyl.volume(), 2.0 * std::numbers::pi, 1e-12);
  EXPECT_NEAR(sphere_fraction_inside(cyl, {0, 0, 1.0}, 0.3, fibonacci_directions(2000)), 0.5, 0.01);
  const Region fit = enclosing_region(p, Region::Kind::cylinder);
  EXPECT_NEAR(fit.radius, 1.0, 0.02);
  // The same bits on one thread as on several (the bins are summed in a fixed order).
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const PairCorrelation one = pair_correlation(p, cyl, 0.6, 12);
  omp_set_num_threads(std::max(2, threads));
  const PairCorrelation many = pair_correlation(p, cyl, 0.6, 12);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.g, many.g);
  EXPECT_EQ(one.g, g.g);
}

TEST(Structure, CoordinationOfALattice) {
  const double a = 1e-3;
  const auto p = cubic_lattice(5, a);
  const std::vector<double> radii(p.size(), 0.5 * a);
  const auto z = coordination_by_distance(p, radii, 1.01);
  EXPECT_EQ(z[index_of(5, 2, 2, 2)], 6u);
  EXPECT_EQ(z[index_of(5, 0, 0, 0)], 3u);
  const CoordinationDistribution d = coordination_distribution(z);
  ASSERT_EQ(d.count.size(), 7u);
  EXPECT_EQ(d.count[6], 27u);  // the 3^3 interior points
  EXPECT_EQ(d.count[3], 8u);   // corners
  EXPECT_NEAR(d.mean, 2.0 * 300.0 / 125.0, 1e-12);  // 3 * 5 * 5 * 4 = 300 links
  EXPECT_EQ(coordination_from_pairs(3, {{0, 1}, {0, 2}}), (std::vector<std::uint32_t>{2, 1, 1}));
}

TEST(Structure, DisplacementDistributionsAreOverD50) {
  std::vector<Eigen::Vector3d> u{{1.2e-4, 0, 0}, {-1.2e-4, 0, 0}, {0, 0, 2.2e-4}, Eigen::Vector3d::Constant(std::nan(""))};
  const auto d = displacement_distributions(u, 1e-3, 0.5, 10);  // components: bins of 0.1 d50; magnitude: 0.05
  EXPECT_EQ(d.component[0].used, 3u);
  EXPECT_EQ(d.component[0].count[3], 1u);  // -0.12
  EXPECT_EQ(d.component[0].count[6], 1u);  // +0.12
  EXPECT_EQ(d.component[2].count[7], 1u);  // +0.22
  EXPECT_EQ(d.magnitude.count[2], 2u);
  EXPECT_EQ(d.magnitude.count[4], 1u);
}

TEST(Forces, DistributionAndWeakForceFit) {
  // Weak forces drawn from (theta + 1) f^theta on (0, 1]: inverse transform f = u^(1 / (theta + 1)).
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double theta = 0.4;
  std::vector<double> weak;
  for (int i = 0; i < 5000; ++i) weak.push_back(std::pow(1.0 - u(rng), 1.0 / (theta + 1.0)));
  const WeakForceFit w = fit_weak_forces(weak);
  ASSERT_TRUE(w.valid);
  EXPECT_NEAR(w.theta, theta, 3.0 * w.theta_error) << w.theta << " +- " << w.theta_error;
  // Forces in N, zero and negative ones (no contact) left out; normalised by their mean.
  const ForceDistribution d = force_distribution({2.0, 4.0, 6.0, 0.0, -1.0, std::nan("")}, 5);
  EXPECT_DOUBLE_EQ(d.mean, 4.0);
  EXPECT_EQ(d.normalised, (std::vector<double>{0.5, 1.0, 1.5}));
  EXPECT_EQ(d.pdf.used, 3u);
  EXPECT_EQ(d.strong.count, 2u);  // f >= 1
  EXPECT_NEAR(d.strong.scale, 0.25, 1e-15);
}

TEST(Forces, RoseOfMeanNormalForce) {
  // Two contacts along z (one pointing down: the same axis) and one along x.
  const ForceRose r = force_rose({{0, 0, 1}, {0, 0, -1}, {1, 0, 0}}, {2.0, 4.0, 1.0}, 3, 4);
  ASSERT_EQ(r.mean_force.size(), 12u);
  EXPECT_EQ(r.counts[0], 2u);
  EXPECT_DOUBLE_EQ(r.mean_force[0], 3.0);
  EXPECT_EQ(r.counts[2 * 4 + 0], 1u);  // theta = pi/2 sits in the last theta bin, phi = 0 in the first
  EXPECT_DOUBLE_EQ(r.mean_force[2 * 4 + 0], 1.0);
  EXPECT_TRUE(std::isnan(r.mean_force[5]));
}

TEST(Forces, GrainStressVolatilityAndCorrelation) {
  const double s = 2e5;
  EXPECT_NEAR(deviatoric_stress_q(Eigen::Vector3d(0, 0, s).asDiagonal()), s / std::sqrt(3.0), 1e-9);
  Eigen::Matrix3d shear = Eigen::Matrix3d::Zero();
  shear(0, 1) = shear(1, 0) = s;
  EXPECT_NEAR(deviatoric_stress_q(shear), s, 1e-9);
  EXPECT_NEAR(deviatoric_stress_q(Eigen::Matrix3d::Identity() * s), 0.0, 1e-9);
  // Returns ln2, -ln2, ln2: sample standard deviation 2 ln2 / sqrt 3. A geometric series has none.
  EXPECT_NEAR(volatility({1.0, 2.0, 1.0, 2.0}), 2.0 * std::log(2.0) / std::sqrt(3.0), 1e-15);
  EXPECT_NEAR(volatility({1.0, 1.1, 1.21, 1.331}), 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(volatility({1.0, 2.0})));
  EXPECT_TRUE(std::isnan(volatility({1.0, 0.0, 1.0})));
  // r = 6 / sqrt 60; t = 3 / sqrt 2 with 3 degrees of freedom, whose tail has a closed form:
  // P(T > t) = 1/2 - (atan(t / sqrt 3) + (t / sqrt 3) / (1 + t^2 / 3)) / pi.
  const Correlation c = pearson({1, 2, 3, 4, 5, std::nan("")}, {2, 4, 5, 4, 5, 1});
  EXPECT_EQ(c.count, 5u);
  EXPECT_NEAR(c.r, 6.0 / std::sqrt(60.0), 1e-15);
  const double x = 3.0 / std::sqrt(2.0) / std::sqrt(3.0);
  EXPECT_NEAR(c.p_value, 2.0 * (0.5 - (std::atan(x) + x / (1.0 + x * x)) / std::numbers::pi), 1e-10);
  EXPECT_EQ(pearson({1, 2, 3}, {2, 4, 6}).p_value, 0.0);
  EXPECT_TRUE(std::isnan(pearson({1, 2}, {1, 2}).r));
}

TEST(Forces, StrongNetworkAndGrainQ) {
  const std::vector<double> fn{1.0, 4.0, 0.0, -2.0, 3.0, 2.0};
  EXPECT_EQ(strong_contacts(fn, 2.5, 1.0), (std::vector<std::size_t>{1, 4}));
  EXPECT_EQ(strong_contacts(fn, 2.5, 0.8), (std::vector<std::size_t>{1, 4, 5}));
  EXPECT_TRUE(strong_contacts(fn, 0.0, 1.0).empty());
  // Two grains: pure pressure (q = 0) and pressure plus a shear tau (q = tau).
  std::vector<double> stress(18, 0.0);
  for (int i : {0, 4, 8}) stress[std::size_t(i)] = 3e5, stress[9 + std::size_t(i)] = 3e5;
  stress[9 + 1] = stress[9 + 3] = 2e4;
  const auto q = grain_q(stress);
  EXPECT_NEAR(q[0], 0.0, 1e-9);
  EXPECT_NEAR(q[1], 2e4, 1e-9);
  EXPECT_THROW(grain_q(std::vector<double>(10)), UsageError);
}

TEST(Simulation, FrameContactsLeavePlatensOutAndProjectTheForce) {
  test::TempDir dir;
  test::LatticeRun run;
  run.side = 2;
  test::write_lattice_results(dir / "r.h5", run);
  const SimulationGrains grains = read_simulation_grains(dir / "r.h5");
  ASSERT_EQ(grains.label.size(), 8u);
  EXPECT_NEAR(grains.psd.d50, std::cbrt(6.0 / std::numbers::pi) * run.box, 1e-15);
  fdem::ResultsFrame frame;
  frame.pair = {test::lattice_label(0), test::lattice_label(1), test::lattice_label(2), 0};
  frame.platen = {-1, 1};
  frame.normal = {0, 1, 0, 0, 0, -1};
  frame.force = {0.5, 7, 2, 0, 0, -50};
  const FrameContacts c = frame_contacts(frame, grains, dir / "r.h5", 0);
  ASSERT_EQ(c.pair.size(), 1u);
  EXPECT_EQ(c.pair[0], (std::pair<std::size_t, std::size_t>{0, 1}));
  EXPECT_DOUBLE_EQ(c.normal_force[0], 7.0);  // F . n: the tangential parts drop out
  EXPECT_EQ(c.platen_contacts, 1u);
  frame.pair[1] = 999;  // a label the grain table lacks
  EXPECT_THROW(frame_contacts(frame, grains, dir / "r.h5", 0), DataError);
  frame.force.pop_back();
  EXPECT_THROW(frame_contacts(frame, grains, dir / "r.h5", 0), DataError);
  // Every frame as a state, coordination from the (contact-free) frames.
  std::vector<double> times;
  const SeriesStates s = simulation_states(dir / "r.h5", grains, &times);
  EXPECT_EQ(s.states, run.frames);
  EXPECT_NEAR(times[2], 2.0 * double(run.steps_per_frame) * run.dt, 1e-15);
  EXPECT_LT((s.position[7 * s.states] - test::lattice_site(run, 7)).norm(), 1e-15);
  EXPECT_EQ(s.coordination[1], std::vector<std::uint32_t>(8, 0));
}

TEST(Simulation, BranchRosesAreOfTheGrainGrainContactsCentroidToCentroid) {
  test::TempDir dir;
  test::LatticeRun run;
  run.side = 2;
  test::write_lattice_results(dir / "r.h5", run);
  // Grain 0 touches its neighbours along x (1), across the xy diagonal (3), along z (4) and across
  // the xz diagonal (5); grain 2 touches a platen, which no branch vector joins.
  test::set_frame_contacts(dir / "r.h5", 1, {{0, 1}, {0, 3}, {0, 4}, {0, 5}, {2, 0, 1}});
  const auto roses = simulation_branch_roses(dir / "r.h5", {0, 1}, 3, 1);
  ASSERT_EQ(roses.size(), 2u);
  EXPECT_EQ(roses[0].counts, std::vector<std::uint64_t>(3, 0));  // the lattice's frames have no contact
  // Polar bands of 30 degrees from z: z, then the xz diagonal at 45, then x and xy at 90.
  EXPECT_EQ(roses[1].counts, (std::vector<std::uint64_t>{1, 1, 2}));
}

TEST(Simulation, BadGrainTablesAndNoFramesAreDataErrors) {
  test::TempDir dir;
  test::LatticeRun run;
  run.side = 2;
  run.frames = 0;
  test::write_lattice_results(dir / "empty.h5", run);
  const SimulationGrains grains = read_simulation_grains(dir / "empty.h5");
  EXPECT_THROW(simulation_states(dir / "empty.h5", grains, nullptr), DataError);
  test::replace_dataset(dir / "empty.h5", schema::fdem_results::grain_label, std::vector<std::uint32_t>(8, 5), {8});
  EXPECT_THROW(read_simulation_grains(dir / "empty.h5"), DataError);
  test::replace_dataset(dir / "empty.h5", schema::fdem_results::grain_volume, std::vector<double>(3, 1e-9), {3});
  EXPECT_THROW(read_simulation_grains(dir / "empty.h5"), DataError);
}

TEST(Structure, EnclosingRegionHoldsEveryPoint) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<Eigen::Vector3d> p(27);
    for (auto& q : p) q = Eigen::Vector3d(u(rng), u(rng), u(rng));
    for (const auto kind : {Region::Kind::box, Region::Kind::cylinder}) {
      const Region r = enclosing_region(p, kind);
      for (const auto& q : p) EXPECT_TRUE(r.contains(q)) << trial;
    }
  }
}
