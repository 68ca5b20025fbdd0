// Grading curves and prescribed triaxial kinematics of synthetic series.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/synth/loading.hpp"
#include "graintwin/synth/psd.hpp"

using namespace graintwin;
using namespace graintwin::synth;

TEST(Psd, OttawaSamplesHaveTheRightBoundsAndMassMedian) {
  Psd psd;
  std::mt19937_64 rng(3);
  const auto d = sample_diameters(psd, 5e-6, rng);  // about 50 000 grains
  ASSERT_GT(d.size(), 10000u);
  for (double x : d) {
    ASSERT_GE(x, psd.d_min);
    ASSERT_LE(x, psd.d_max);
  }
  std::vector<double> volume;
  for (double x : d) volume.push_back(std::numbers::pi / 6.0 * x * x * x);
  EXPECT_NEAR(d50_of_volumes(volume) / psd.d50, 1.0, 0.02);
  EXPECT_NEAR(psd.percent_passing(psd.d50), 50.0, 1.0);
  EXPECT_DOUBLE_EQ(psd.percent_passing(0.2e-3), 0.0);
  EXPECT_DOUBLE_EQ(psd.percent_passing(2e-3), 100.0);
}

TEST(Psd, RejectsInconsistentSizes) {
  Psd psd;
  psd.d50 = 2e-3;
  try {
    psd.validate();
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "grain sizes must satisfy 0 < d-min <= d50 <= d-max (got 0.3, 2, 1.03 mm); reorder --d-min, "
                           "--d50 and --d-max");
  }
}

TEST(Psd, ExpectedGrainCountMatchesTheDraw) {
  // ctsynth checks a sample's cost from this estimate before drawing it.
  for (const double sigma : {0.1, 0.25, 0.6}) {
    Psd psd;
    psd.sigma_ln = sigma;
    std::mt19937_64 rng(5);
    const double volume = 2e-6;
    const auto drawn = static_cast<double>(sample_diameters(psd, volume, rng).size());
    EXPECT_NEAR(expected_grain_count(psd, volume) / drawn, 1.0, 0.03) << "sigma " << sigma;
  }
  Psd one_size{0.5e-3, 0.5e-3, 0.5e-3, 0.25};
  EXPECT_NEAR(expected_grain_count(one_size, 1e-6), 1e-6 / (M_PI / 6.0 * 0.125e-9), 1e-6);
}

namespace {
LoadingParams sample() {
  LoadingParams p;
  p.height = 10e-3;
  p.radius = 3e-3;
  p.band_width = 5e-3;
  return p;
}
}  // namespace

TEST(Loading, AffinePartCompressesAndBulges) {
  LoadingParams p = sample();
  p.band = ShearBand::none;
  const double eps = 0.02;
  // Top platen centre moves down by eps H; the base does not move.
  EXPECT_NEAR(smooth_displacement(p, {0, 0, p.height}, eps).z(), -eps * p.height, 1e-15);
  EXPECT_NEAR(smooth_displacement(p, {0, 0, 0}, eps).norm(), 0.0, 1e-15);
  // At mid-height the membrane bulges by 1.5 * bulge * eps (barrel profile with mean 1).
  EXPECT_NEAR(smooth_displacement(p, {p.radius, 0, 0.5 * p.height}, eps).x(), p.radius * 1.5 * 0.5 * eps, 1e-15);
  EXPECT_NEAR(sample_radius_at(p, 0.5 * p.height * (1 - eps), eps), p.radius * (1 + 0.75 * eps), 1e-12);
}

TEST(Loading, BandSlipsTheUpperBlockDownTheDip) {
  LoadingParams p = sample();
  p.bulge = 0.0;
  p.band_width = 1e-3;  // narrow enough that both test points are outside the band
  const double eps = 0.05;
  const Eigen::Vector3d above(0, 0, 0.95 * p.height), below(0, 0, 0.05 * p.height);
  const Eigen::Vector3d jump = (smooth_displacement(p, above, eps) + Eigen::Vector3d(0, 0, eps * above.z())) -
                               (smooth_displacement(p, below, eps) + Eigen::Vector3d(0, 0, eps * below.z()));
  EXPECT_NEAR(jump.norm(), p.band_slip * eps * p.height, 1e-3 * p.band_slip * eps * p.height);
  EXPECT_LT(jump.z(), 0.0);  // the upper block goes down
  EXPECT_NEAR(std::atan2(-jump.z(), -jump.x()) * 180 / M_PI, p.band_angle_deg, 1e-6);
  EXPECT_GT(local_shear(p, {0, 0, 0.5 * p.height}, eps), 5 * local_shear(p, below, eps));
}

TEST(Loading, StatesAreCumulativeAndDeterministic) {
  LoadingParams p = sample();
  std::vector<PackedGrain> ref(50);
  for (std::size_t i = 0; i < ref.size(); ++i) ref[i].position = Eigen::Vector3d(1e-4 * (i % 20), 0.0, 2e-4 * i);
  const auto a = loading_states(p, ref, {0.0, 0.01, 0.02});
  const auto b = loading_states(p, ref, {0.0, 0.01, 0.02});
  ASSERT_EQ(a.size(), 3u);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_EQ(a[0][i].position, ref[i].position);  // state 0 at zero strain is the reference
    EXPECT_EQ(a[2][i].position, b[2][i].position);
    EXPECT_TRUE(a[2][i].orientation.isApprox(b[2][i].orientation));
  }
  EXPECT_FALSE(a[1][10].orientation.isApprox(Eigen::Quaterniond::Identity()));
  p.band_width = 0.0;
  EXPECT_THROW(loading_states(p, ref, {0.0, 0.01}), UsageError);
}

namespace {
// Per grain, the random part of its motion from state 0 to 1: the state minus the smooth field.
std::vector<Eigen::Vector3d> random_motion(const LoadingParams& p, const std::vector<PackedGrain>& ref, double eps) {
  const auto states = loading_states(p, ref, {0.0, eps});
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < ref.size(); ++i)
    out.push_back(states[1][i].position - ref[i].position - smooth_displacement(p, ref[i].position, eps));
  return out;
}
}  // namespace

TEST(Loading, CorrelatedNonaffineMotionKeepsItsStdAndMovesNeighboursTogether) {
  LoadingParams p = sample();
  p.band_width = 1.0;  // so wide that every grain is in its middle: band weight 1, the same std for all
  const double eps = 0.02, sigma = p.nonaffine * p.band_slip * eps * p.height;
  // Pairs of grains 0.2 mm apart on a lattice of 2 mm: pairs far from each other, close within.
  std::vector<PackedGrain> ref;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 5; ++k)
        for (double dx : {0.0, 0.2e-3}) {
          PackedGrain g;
          g.position = Eigen::Vector3d(-3e-3 + 2e-3 * i + dx, -3e-3 + 2e-3 * j, 1e-3 + 2e-3 * k);
          ref.push_back(g);
        }
  const auto spread = [&](double correlation) {
    p.nonaffine_correlation = correlation;
    const auto u = random_motion(p, ref, eps);
    double own = 0, relative = 0;
    for (std::size_t i = 0; i < u.size(); i += 2) {
      own += u[i].squaredNorm() + u[i + 1].squaredNorm();
      relative += (u[i + 1] - u[i]).squaredNorm();
    }
    const double pairs = static_cast<double>(u.size() / 2);
    return std::pair{std::sqrt(own / (2 * pairs * 3)), std::sqrt(relative / (pairs * 3))};
  };
  const auto [own_independent, relative_independent] = spread(0.0);
  const auto [own_correlated, relative_correlated] = spread(2e-3);
  // Each grain's std is sigma either way (160 draws of 3 components: within 15 %).
  EXPECT_NEAR(own_independent / sigma, 1.0, 0.15);
  EXPECT_NEAR(own_correlated / sigma, 1.0, 0.15);
  // Independent neighbours differ by sqrt(2) sigma; over a tenth of the correlation length, by a
  // small fraction of it.
  EXPECT_NEAR(relative_independent / sigma, std::sqrt(2.0), 0.25);
  EXPECT_LT(relative_correlated / sigma, 0.2);
  // The same draw again; a too short length and a negative one are refused before any work.
  p.nonaffine_correlation = 2e-3;
  EXPECT_EQ(random_motion(p, ref, eps)[7], random_motion(p, ref, eps)[7]);
  p.nonaffine_correlation = 1e-9;
  EXPECT_THROW(loading_states(p, ref, {0.0, eps}), UsageError);
  p.nonaffine_correlation = -1e-3;
  EXPECT_THROW(loading_states(p, ref, {0.0, eps}), UsageError);
}
