// Partial-volume rendering and the scanner model against exact answers.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/synth/render.hpp"

using namespace graintwin;
using namespace graintwin::synth;

namespace {
const Vec3 kVoxel{1e-5, 1e-5, 1e-5};
double sum(const Volume<float>& v) { return std::accumulate(v.values().begin(), v.values().end(), 0.0); }
}  // namespace

TEST(Render, SphereVolumeFromPartialVolumesWithinHalfAPercent) {
  // Radius 6.3 voxels at an off-grid centre: the partial-volume sum must give 4/3 pi r^3 within
  // 0.5 %, with the analytic default (measured: 0.002 %) and with 4^3 point samples.
  const double r = 6.3e-5;
  const auto sphere = shape::RadialTable::from_function([&](const Eigen::Vector3d&) { return r; }, 16);
  PlacedGrain g{&sphere, {1.0137e-4, 0.9871e-4, 1.0411e-4}, Eigen::Quaterniond::Identity(), 1};
  const double exact = 4.0 / 3.0 * M_PI * r * r * r;
  for (int k : {0, 4}) {
    const GrainImages im = render_grains({g}, {21, 21, 21}, kVoxel, {0, 0, 0}, RenderParams{k});
    EXPECT_NEAR(sum(im.fraction) * 1e-15 / exact, 1.0, 0.005) << "supersample " << k;
    // Labelled voxels (centre inside) approximate the volume to within the voxelisation error.
    const auto labelled = std::count(im.labels.values().begin(), im.labels.values().end(), 1u);
    EXPECT_NEAR(labelled * 1e-15 / exact, 1.0, 0.03);
  }
}

namespace {
// Fraction of the unit voxel with lower corner lo (voxel units) inside the sphere |x - c| <= r:
// the z-extent inside both, integrated over x and y by the midpoint rule on n x n points (exact
// to ~1e-5 for n = 400: the integrand is continuous).
double voxel_in_sphere(const Eigen::Vector3d& lo, const Eigen::Vector3d& c, double r, int n) {
  double s = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double x = lo.x() + (i + 0.5) / n - c.x(), y = lo.y() + (j + 0.5) / n - c.y();
      const double h2 = r * r - x * x - y * y;
      if (h2 <= 0.0) continue;
      const double h = std::sqrt(h2);
      s += std::max(0.0, std::min(lo.z() + 1.0, c.z() + h) - std::max(lo.z(), c.z() - h));
    }
  }
  return s / (n * n);
}
}  // namespace

TEST(Render, AnalyticFractionsOfASphereVoxelByVoxel) {
  // Every voxel within a voxel of a 6.3-voxel sphere's surface against its exact fraction.
  // Measured: rms 0.0019, worst 0.007; 4^3 point samples give rms 0.012, worst 0.09.
  const double r = 6.3;
  const auto sphere = shape::RadialTable::from_function([&](const Eigen::Vector3d&) { return r * 1e-5; }, 16);
  const Eigen::Vector3d c(10.137, 9.771, 10.311);  // voxel units; voxel (z, y, x) has centre (x, y, z)
  PlacedGrain g{&sphere, c * 1e-5, Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized())), 1};
  const GrainImages im = render_grains({g}, {21, 21, 21}, kVoxel, {0, 0, 0}, RenderParams{});
  double sum_sq = 0.0, worst = 0.0;
  int n = 0;
  for (std::size_t z = 0; z < 21; ++z) {
    for (std::size_t y = 0; y < 21; ++y) {
      for (std::size_t x = 0; x < 21; ++x) {
        const Eigen::Vector3d centre(x, y, z);
        if (std::abs((centre - c).norm() - r) > 1.0) continue;
        const double e = im.fraction(z, y, x) - voxel_in_sphere(centre - Eigen::Vector3d::Constant(0.5), c, r, 400);
        sum_sq += e * e;
        worst = std::max(worst, std::abs(e));
        ++n;
      }
    }
  }
  EXPECT_GT(n, 900);
  EXPECT_LT(std::sqrt(sum_sq / n), 0.004);
  EXPECT_LT(worst, 0.02);
}

TEST(Render, BoxFractionBelowPlane) {
  const Eigen::Vector3d edges(1.0, 2.0, 0.5);
  // Normal along an axis: a slab.
  EXPECT_NEAR(box_fraction_below_plane({0, 1, 0}, 0.3, edges), 0.5 + 0.3 / 2.0, 1e-15);
  EXPECT_NEAR(box_fraction_below_plane({0, 0, -1}, 0.1, edges), 0.5 + 0.1 / 0.5, 1e-15);
  EXPECT_EQ(box_fraction_below_plane({1, 0, 0}, 0.6, edges), 1.0);
  EXPECT_EQ(box_fraction_below_plane({1, 0, 0}, -0.6, edges), 0.0);
  // A corner of the unit cube (centred at 0): x + y + z >= 3/2 - t is a tetrahedron of volume
  // t^3 / 6.
  const Eigen::Vector3d diag = Eigen::Vector3d::Ones().normalized();
  const double t = 0.2;
  EXPECT_NEAR(box_fraction_below_plane(-diag, -(1.5 - t) / std::sqrt(3.0), Eigen::Vector3d::Ones()),
              std::pow(t, 3) / 6.0, 1e-14);
  // Random planes against the exact z-extent integrated over x, y (midpoint rule, 600^2 points:
  // the integrand is piecewise linear, so the reference is good to ~1e-6), with complements.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> u(-0.9, 0.9);
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::Vector3d n(nd(rng), nd(rng), nd(rng));
    if (trial % 4 == 1) n.x() = 1e-12;  // nearly along an edge or a face: the formula's edge cases
    if (trial % 4 == 2) n.y() = n.x() = 1e-9;
    n.normalize();
    const double offset = u(rng) * 0.5 * n.cwiseAbs().dot(edges);
    const int m = 600;
    double ref = 0.0;
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        const double x = ((i + 0.5) / m - 0.5) * edges.x(), y = ((j + 0.5) / m - 0.5) * edges.y();
        const double rest = offset - n.x() * x - n.y() * y;  // n.z z <= rest
        const double lo = -0.5 * edges.z(), hi = 0.5 * edges.z();
        double len;
        if (n.z() > 0.0) len = std::clamp(rest / n.z(), lo, hi) - lo;
        else if (n.z() < 0.0) len = hi - std::clamp(rest / n.z(), lo, hi);
        else len = rest >= 0.0 ? hi - lo : 0.0;
        ref += len / edges.z();
      }
    }
    ref /= m * m;
    const double f = box_fraction_below_plane(n, offset, edges);
    EXPECT_NEAR(f, ref, 2e-5) << "trial " << trial;
    EXPECT_NEAR(f + box_fraction_below_plane(-n, -offset, edges), 1.0, 1e-12) << "trial " << trial;
  }
}

TEST(Render, RotatedEllipsoidVolumeMatchesItsTable) {
  const auto ell = shape::ellipsoid_table(9e-5, 6e-5, 4.5e-5, 64);
  PlacedGrain g{&ell, {1.6e-4, 1.55e-4, 1.62e-4},
                Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())), 5};
  for (int k : {0, 5}) {
    const GrainImages im = render_grains({g}, {33, 33, 33}, kVoxel, {0, 0, 0}, RenderParams{k});
    // Analytic: within 0.05 % of the table's volume; point samples within 0.5 %.
    EXPECT_NEAR(sum(im.fraction) * 1e-15 / ell.volume(), 1.0, k == 0 ? 0.0005 : 0.005) << "supersample " << k;
    EXPECT_EQ(im.labels(16, 16, 16), 5u);
    EXPECT_EQ(im.labels(0, 0, 0), 0u);
  }
}

TEST(Render, GrainsCutByTheVolumeEdgeAreClipped) {
  const auto sphere = shape::RadialTable::from_function([](const Eigen::Vector3d&) { return 5e-5; }, 16);
  PlacedGrain g{&sphere, {0.0, 1e-4, 1e-4}, Eigen::Quaterniond::Identity(), 1};  // centre on the x = 0 face
  const GrainImages im = render_grains({g}, {20, 20, 20}, kVoxel, {0, 0, 0}, RenderParams{4});
  // Half the sphere lies at x >= 0, plus half a voxel slab of the clipped half (voxel 0 spans x -0.5..0.5).
  const double half = 2.0 / 3.0 * M_PI * 1.25e-13;
  EXPECT_NEAR(sum(im.fraction) * 1e-15, half + M_PI * 25e-10 * 0.5e-5, 0.01 * half);
}

TEST(Render, ShellVolumeIsTheAnnulusVolume) {
  Shell sh;
  sh.centre_x = sh.centre_y = 2e-4;
  sh.inner_radius = [](double, double) { return 1.2e-4; };
  sh.thickness = 0.3e-4;
  sh.z0 = 0.5e-4;
  sh.z1 = 2.5e-4;
  std::vector<double> progress;
  const Volume<float> f =
      render_shell(sh, {30, 41, 41}, kVoxel, {0, 0, 0}, RenderParams{}, [&](double done) { progress.push_back(done); });
  const double exact = M_PI * (1.5e-4 * 1.5e-4 - 1.2e-4 * 1.2e-4) * 2e-4;
  EXPECT_NEAR(sum(f) * 1e-15 / exact, 1.0, 0.01);
  // Every slice is reported once, those the shell misses too.
  ASSERT_EQ(progress.size(), 30u);
  EXPECT_DOUBLE_EQ(*std::max_element(progress.begin(), progress.end()), 1.0);
}

TEST(Render, BlurConservesTheTotal) {
  Volume<float> v({20, 20, 20}, kVoxel);
  v(10, 10, 10) = 1.0f;
  v(9, 12, 10) = 2.0f;
  gaussian_blur(v, 1.2);
  EXPECT_NEAR(sum(v), 3.0, 1e-5);
  EXPECT_LT(v(10, 10, 10), 0.1f);
}

TEST(Scanner, GreyLevelsNoiseAndDeterminism) {
  Volume<float> frac({16, 16, 16}, kVoxel);
  for (std::size_t i = 0; i < frac.size() / 2; ++i) frac.values()[i] = 1.0f;  // z < 8: grain
  ScannerParams p;
  p.blur_sigma_vox = 0.0;
  p.noise = 0.05;
  p.seed = 7;
  omp_set_num_threads(1);
  const auto a = simulate_scan(frac, nullptr, p);
  omp_set_num_threads(2);
  const auto b = simulate_scan(frac, nullptr, p);
  EXPECT_EQ(a.values(), b.values()) << "noise must not depend on the thread count";
  // Mean and spread of the grain half: grey 0.75 -> 0.75*50000+5000, sigma 0.05 * 0.65 * 50000.
  double m = 0, m2 = 0;
  const std::size_t n = a.size() / 2;
  for (std::size_t i = 0; i < n; ++i) {
    m += a.values()[i];
    m2 += static_cast<double>(a.values()[i]) * a.values()[i];
  }
  m /= n;
  const double sd = std::sqrt(m2 / n - m * m);
  EXPECT_NEAR(m, 42500.0, 3 * 1625.0 / std::sqrt(n) + 1);
  EXPECT_NEAR(sd, 1625.0, 0.1 * 1625.0);
  p.seed = 8;
  EXPECT_NE(simulate_scan(frac, nullptr, p).values(), a.values());
}

TEST(Scanner, PoissonNoiseScalesWithTheSignal) {
  Volume<float> frac({8, 32, 32}, kVoxel, {0, 0, 0}, 1.0f);
  ScannerParams p;
  p.blur_sigma_vox = 0.0;
  p.noise = 0.0;
  p.photons = 400.0;  // relative sigma 1/20 at grain grey
  const auto a = simulate_scan(frac, nullptr, p);
  double m = 0, m2 = 0;
  for (auto x : a.values()) {
    const double g = (x - p.uint16_offset) / p.uint16_scale;
    m += g;
    m2 += g * g;
  }
  m /= a.size();
  EXPECT_NEAR(std::sqrt(m2 / a.size() - m * m) / m, 0.05, 0.005);
}

TEST(Render, RejectsSillySupersampling) {
  EXPECT_THROW(render_grains({}, {2, 2, 2}, kVoxel, {0, 0, 0}, RenderParams{-1}), UsageError);
  EXPECT_THROW(render_grains({}, {2, 2, 2}, kVoxel, {0, 0, 0}, RenderParams{17}), UsageError);
}

TEST(Scanner, GreyLevelsThatSaturateOrLoseTheContrastAreRefused) {
  ScannerParams p;  // void 0.10, grain 0.75, membrane 0.35, scale 50000, offset 5000
  EXPECT_NO_THROW(check_grey_levels(p, true));
  const auto message = [](const ScannerParams& q, bool membrane) {
    try {
      check_grey_levels(q, membrane);
    } catch (const UsageError& e) {
      return e.message();
    }
    return std::string();
  };
  p.uint16_scale = 1e12;  // every grain voxel would be 65535, every pore too: a binary scan
  EXPECT_EQ(message(p, true), "--grey-scale 1e+12 and --grey-offset 5000 put --grey-void 0.1 at uint16 value 1e+11, outside "
                              "0..65535, so every such voxel would saturate; give --grey-scale of at most 80713 or lower --grey-offset");
  p.uint16_scale = 1e-3;
  EXPECT_NE(message(p, false).find("same value; give --grey-scale of at least 1.54"), std::string::npos);
  p.uint16_scale = 50000;
  p.grey_membrane = 2.0;  // only checked when there is a membrane
  EXPECT_NO_THROW(check_grey_levels(p, false));
  EXPECT_NE(message(p, true).find("--grey-membrane 2"), std::string::npos);
  p.grey_membrane = 0.35;
  p.grey_void = -0.2;
  EXPECT_NE(message(p, false).find("raise --grey-offset to at least 10000"), std::string::npos);
  p.grey_void = 0.8;
  EXPECT_NE(message(p, false).find("--grey-grain 0.75 is not above --grey-void 0.8"), std::string::npos);
}

TEST(Scanner, NanBlurOrNoiseIsAnErrorNotACrash) {
  const Volume<float> fraction({4, 4, 4}, kVoxel);
  for (double ScannerParams::*field : {&ScannerParams::blur_sigma_vox, &ScannerParams::noise, &ScannerParams::photons}) {
    ScannerParams p;
    p.*field = std::nan("");
    EXPECT_THROW(simulate_scan(fraction, nullptr, p), UsageError);
  }
  Volume<float> v({4, 4, 4}, kVoxel);
  EXPECT_THROW(gaussian_blur(v, std::nan("")), UsageError);
  EXPECT_THROW(gaussian_blur(v, HUGE_VAL), UsageError);
}
