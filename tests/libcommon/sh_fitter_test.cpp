// The shared-design-matrix SH fitter: exact recovery of band-limited radii, truncation residuals,
// conditioning guard, exact moments, and the sphere quadrature.
#include <gtest/gtest.h>
#include <omp.h>
#include <time.h>

#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"

using namespace graintwin;
using namespace graintwin::shape;

namespace {
Eigen::VectorXd random_coeffs(int degree, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.05);
  Eigen::VectorXd c(sh_count(degree));
  for (auto& v : c) v = g(rng);
  c[0] = 2.0;
  return c;
}
}  // namespace

TEST(ShFitter, RecoversBandLimitedRadiiExactly) {
  const ShFitter f(10);
  EXPECT_EQ(f.degree(), 10);
  EXPECT_TRUE(f.warning().empty());
  EXPECT_LT(f.condition_number(), 1.5);
  const Eigen::VectorXd c = random_coeffs(10, 3);
  const Eigen::VectorXd r = f.design() * c;
  EXPECT_LT((f.fit(r) - c).norm(), 1e-12);
  // Truncation: a degree-4 surface has no residual from degree 4 on.
  Eigen::VectorXd c4 = c;
  c4.tail(c.size() - sh_count(4)).setZero();
  const Eigen::VectorXd t = f.truncation_rms(f.design() * c4, f.fit(f.design() * c4));
  EXPECT_GT(t[3], 1e-3);
  for (int n = 4; n <= 10; ++n) EXPECT_LT(t[n], 1e-12) << n;
}

TEST(ShFitter, LowersADegreeTheDirectionsCannotCarry) {
  const ShFitter f(15, 100);  // 256 coefficients from 100 directions
  EXPECT_LT(f.degree(), 10);
  EXPECT_EQ(f.requested_degree(), 15);
  EXPECT_NE(f.warning().find("lowered"), std::string::npos);
  EXPECT_LE(f.condition_number(), ShFitter::kMaxCondition);
  EXPECT_THROW(ShFitter(-1), UsageError);
}

TEST(ShFitter, MomentsOfASphereAndAShiftedBody) {
  const ShFitter f(6);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(sh_count(6));
  c[0] = 3.0 * std::sqrt(4 * std::numbers::pi);
  const BodyMoments m = f.moments(c);
  EXPECT_NEAR(m.volume, 4.0 / 3.0 * std::numbers::pi * 27.0, 1e-9);
  EXPECT_LT(m.centroid.norm(), 1e-12);
  // Against the general integrator for a random body.
  const Eigen::VectorXd r = random_coeffs(6, 9);
  const ShMoments ref = sh_moments(r, 6);
  EXPECT_NEAR(f.moments(r).volume, ref.volume, 1e-10 * ref.volume);
  EXPECT_LT((f.moments(r).centroid - ref.centroid).norm(), 1e-10);
}

TEST(SphereQuadrature, WeightsSumToTheSphereArea) {
  const SphereQuadrature q = sphere_quadrature(7, 14);
  ASSERT_EQ(q.directions.size(), 98u);
  double w = 0.0, z2 = 0.0;
  for (std::size_t i = 0; i < q.weights.size(); ++i) {
    w += q.weights[i];
    z2 += q.weights[i] * q.directions[i].z() * q.directions[i].z();
    EXPECT_NEAR(q.directions[i].norm(), 1.0, 1e-14);
  }
  EXPECT_NEAR(w, 4 * std::numbers::pi, 1e-12);
  EXPECT_NEAR(z2, 4 * std::numbers::pi / 3, 1e-12);
}

TEST(ShFitter, ThousandThreadsDoNotSpinThroughTheSvd) {
  // Eigen's parallel products wait by spinning: with -j 1024 on a few processors the fitter's SVD
  // burnt seconds of CPU in threads waiting for each other. The threads are started first (their
  // creation is not the fitter's cost), then the fitter's CPU time is compared with one thread's.
  const auto cpu_seconds = [] {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
  };
  omp_set_num_threads(1);
  double start = cpu_seconds();
  const ShFitter one(15, 0);
  const double single = cpu_seconds() - start;
  omp_set_num_threads(1024);
#pragma omp parallel
  {
  }
  start = cpu_seconds();
  const ShFitter many(15, 0);
  const double spread = cpu_seconds() - start;
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_LT(spread, 4.0 * single + 0.3) << "one thread: " << single << " s of CPU";
  EXPECT_EQ(many.degree(), one.degree());
}
