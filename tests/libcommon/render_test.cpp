// Partial-volume rendering and the scanner model against exact answers.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <numeric>

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
  // Radius 6.3 voxels at an off-grid centre: the partial-volume sum must give 4/3 pi r^3 within 0.5 %.
  const double r = 6.3e-5;
  const auto sphere = shape::RadialTable::from_function([&](const Eigen::Vector3d&) { return r; }, 16);
  PlacedGrain g{&sphere, {1.0137e-4, 0.9871e-4, 1.0411e-4}, Eigen::Quaterniond::Identity(), 1};
  const GrainImages im = render_grains({g}, {21, 21, 21}, kVoxel, {0, 0, 0}, RenderParams{4});
  const double v = sum(im.fraction) * 1e-15;
  const double exact = 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_NEAR(v / exact, 1.0, 0.005);
  // Labelled voxels (centre inside) approximate the volume to within the voxelisation error.
  const auto labelled = std::count(im.labels.values().begin(), im.labels.values().end(), 1u);
  EXPECT_NEAR(labelled * 1e-15 / exact, 1.0, 0.03);
}

TEST(Render, RotatedEllipsoidVolumeMatchesItsTable) {
  const auto ell = shape::ellipsoid_table(9e-5, 6e-5, 4.5e-5, 64);
  PlacedGrain g{&ell, {1.6e-4, 1.55e-4, 1.62e-4},
                Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())), 5};
  const GrainImages im = render_grains({g}, {33, 33, 33}, kVoxel, {0, 0, 0}, RenderParams{5});
  EXPECT_NEAR(sum(im.fraction) * 1e-15 / (4.0 / 3.0 * M_PI * 9e-5 * 6e-5 * 4.5e-5), 1.0, 0.005);
  EXPECT_EQ(im.labels(16, 16, 16), 5u);
  EXPECT_EQ(im.labels(0, 0, 0), 0u);
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
  sh.inner_radius = [](double) { return 1.2e-4; };
  sh.thickness = 0.3e-4;
  sh.z0 = 0.5e-4;
  sh.z1 = 2.5e-4;
  const Volume<float> f = render_shell(sh, {30, 41, 41}, kVoxel, {0, 0, 0}, 4);
  const double exact = M_PI * (1.5e-4 * 1.5e-4 - 1.2e-4 * 1.2e-4) * 2e-4;
  EXPECT_NEAR(sum(f) * 1e-15 / exact, 1.0, 0.01);
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
  EXPECT_THROW(render_grains({}, {2, 2, 2}, kVoxel, {0, 0, 0}, RenderParams{0}), UsageError);
}
