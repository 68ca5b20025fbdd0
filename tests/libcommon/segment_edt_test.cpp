// Exact Euclidean distance transform: brute force on random anisotropic masks, border modes,
// a sphere, degenerate masks.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/edt.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

Volume<std::uint8_t> random_mask(Shape3 shape, Vec3 voxel, double solid_fraction, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Volume<std::uint8_t> m(shape, voxel);
  for (auto& v : m.values()) v = (rng() % 1000) < solid_fraction * 1000 ? 1 : 0;
  return m;
}

/// Squared distance from each solid voxel to the nearest background voxel centre, by testing every
/// pair; with border_bg the background also fills one layer around the volume.
std::vector<double> brute_force(const Volume<std::uint8_t>& m, bool border_bg) {
  const Shape3 s = m.shape();
  const Vec3 a = m.voxel_size();
  std::vector<double> d(m.size(), 0.0);
  for (long z = 0; z < long(s[0]); ++z)
    for (long y = 0; y < long(s[1]); ++y)
      for (long x = 0; x < long(s[2]); ++x) {
        if (!m(z, y, x)) continue;
        double best = std::numeric_limits<double>::infinity();
        const long lo = border_bg ? -1 : 0;
        for (long zz = lo; zz <= long(s[0]) - 1 - lo; ++zz)
          for (long yy = lo; yy <= long(s[1]) - 1 - lo; ++yy)
            for (long xx = lo; xx <= long(s[2]) - 1 - lo; ++xx) {
              const bool outside = zz < 0 || yy < 0 || xx < 0 || zz >= long(s[0]) || yy >= long(s[1]) || xx >= long(s[2]);
              if (!outside && m(zz, yy, xx)) continue;
              const double dz = (zz - z) * a[0], dy = (yy - y) * a[1], dx = (xx - x) * a[2];
              best = std::min(best, dz * dz + dy * dy + dx * dx);
            }
        d[m.index(z, y, x)] = best;
      }
  return d;
}

}  // namespace

TEST(Edt, MatchesBruteForceOnRandomAnisotropicMasks) {
  const Vec3 voxel{3e-5, 1.7e-5, 1e-5};  // dz, dy, dx all different
  int checked = 0;
  for (std::uint32_t seed = 1; seed <= 12; ++seed) {
    const double fraction = 0.5 + 0.04 * seed;  // up to 98 % solid: long runs without background
    const Shape3 shape{5 + seed % 4, 7 + seed % 3, 9 + seed % 5};
    const auto m = random_mask(shape, voxel, fraction, seed);
    for (bool border_bg : {false, true}) {
      const auto expect = brute_force(m, border_bg);
      const auto d2 = squared_distance_transform(m, voxel, border_bg);
      const auto d = distance_transform(m, border_bg);
      for (std::size_t i = 0; i < m.size(); ++i) {
        if (std::isinf(expect[i])) {
          EXPECT_TRUE(std::isinf(d2.values()[i]));
          continue;
        }
        ASSERT_NEAR(d2.values()[i], expect[i], 1e-6 * expect[i] + 1e-30) << "seed " << seed << " voxel " << i;
        ASSERT_NEAR(d.values()[i], std::sqrt(expect[i]), 1e-6 * std::sqrt(expect[i])) << "seed " << seed;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 5000);
}

TEST(Edt, LongLinesUseTheBlockedPassesCorrectly) {
  // Wider than one 16-column block and taller than the other axes, with a ragged last block.
  const Vec3 voxel{1.0, 2.0, 0.5};
  const auto m = random_mask({23, 6, 37}, voxel, 0.93, 99);
  const auto expect = brute_force(m, false);
  const auto d2 = squared_distance_transform(m, voxel);
  for (std::size_t i = 0; i < m.size(); ++i)
    if (!std::isinf(expect[i])) {
      ASSERT_NEAR(d2.values()[i], expect[i], 1e-5 * expect[i]) << i;
    }
}

TEST(Edt, SphereDistancesAreRadiusMinusDistanceFromCentre) {
  const double r = 12.0, c = 15.0, a = 2e-5;
  Volume<std::uint8_t> m({31, 31, 31}, {a, a, a});
  for (std::size_t z = 0; z < 31; ++z)
    for (std::size_t y = 0; y < 31; ++y)
      for (std::size_t x = 0; x < 31; ++x)
        m(z, y, x) = std::hypot(z - c, y - c, x - c) <= r;
  const auto d = distance_transform(m);
  EXPECT_EQ(d.voxel_size(), m.voxel_size());
  // The nearest background voxel centre is within one voxel of the sphere surface.
  for (std::size_t z = 0; z < 31; ++z)
    for (std::size_t y = 0; y < 31; ++y)
      for (std::size_t x = 0; x < 31; ++x) {
        if (!m(z, y, x)) {
          EXPECT_EQ(d(z, y, x), 0.0f);
          continue;
        }
        const double expect = (r - std::hypot(z - c, y - c, x - c)) * a;
        EXPECT_GE(d(z, y, x), expect - 1e-9);
        EXPECT_LE(d(z, y, x), expect + 1.0 * a + 1e-9);
      }
  // The centre: the nearest voxel centres outside r = 12 are at (12, 1, 0) steps, sqrt(145).
  EXPECT_NEAR(d(15, 15, 15), std::sqrt(145.0) * a, 1e-6 * a);
}

TEST(Edt, BorderModeDecidesAboutAMaskWithoutBackground) {
  Volume<std::uint8_t> m({3, 4, 5}, {1.0, 1.0, 1.0}, {0, 0, 0}, 1);
  const auto neutral = distance_transform(m, false);
  for (float v : neutral.values()) EXPECT_TRUE(std::isinf(v));
  const auto bg = distance_transform(m, true);
  EXPECT_FLOAT_EQ(bg(1, 1, 2), 2.0f);  // z: one step to the layer outside
  EXPECT_FLOAT_EQ(bg(0, 0, 0), 1.0f);
  const Volume<std::uint8_t> empty({2, 2, 2});
  const auto zero = distance_transform(empty);
  for (float v : zero.values()) EXPECT_EQ(v, 0.0f);
}

TEST(Edt, RefusesNonPositiveVoxelSize) {
  Volume<std::uint8_t> m({2, 2, 2}, {1.0, 0.0, 1.0});
  EXPECT_THROW(distance_transform(m), UsageError);
}
