// 3x3x3 median filter: brute force with replicated edges, salt noise removal, NaN refusal; Gaussian
// smoothing against the generic blur.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/segment/denoise.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

template <class T>
Volume<T> brute_median(const Volume<T>& v) {
  const Shape3 s = v.shape();
  Volume<T> out(s);
  for (long z = 0; z < long(s[0]); ++z)
    for (long y = 0; y < long(s[1]); ++y)
      for (long x = 0; x < long(s[2]); ++x) {
        std::vector<T> w;
        for (long a = -1; a <= 1; ++a)
          for (long b = -1; b <= 1; ++b)
            for (long c = -1; c <= 1; ++c)
              w.push_back(v(std::clamp(z + a, 0L, long(s[0]) - 1), std::clamp(y + b, 0L, long(s[1]) - 1),
                            std::clamp(x + c, 0L, long(s[2]) - 1)));
        std::sort(w.begin(), w.end());
        out(z, y, x) = w[13];
      }
  return out;
}

template <class T>
void check_random(T range, Shape3 shape = {6, 7, 9}) {
  std::mt19937 rng(7);
  Volume<T> v(shape, {2.0, 1.0, 1.0}, {1.0, 2.0, 3.0});
  for (auto& x : v.values()) x = static_cast<T>(rng() % 1000) * range / T(1000);
  const auto m = median3(v);
  EXPECT_EQ(m.values(), brute_median(v).values());
  EXPECT_EQ(m.voxel_size(), v.voxel_size());
  EXPECT_EQ(m.origin(), v.origin());
}

}  // namespace

TEST(Median3, MatchesBruteForceWithReplicatedEdges) {
  check_random<std::uint8_t>(255);
  check_random<std::uint16_t>(60000);
  check_random<float>(1.0f);
  // Rows longer than the filter's internal chunk of 256 voxels, and degenerate thin volumes.
  check_random<std::uint16_t>(60000, {3, 2, 600});
  check_random<float>(1.0f, {1, 1, 5});
}

TEST(Median3, RemovesSaltNoiseFromPiecewiseConstantImage) {
  // Two flat regions (a step along x) with 2 % isolated salt-and-pepper voxels: the median restores
  // the clean image exactly, step included.
  Volume<std::uint16_t> clean({16, 16, 16});
  for (std::size_t i = 0; i < clean.size(); ++i) clean.values()[i] = (i % 16) < 8 ? 1000 : 3000;
  auto noisy = clean;
  std::mt19937 rng(1);
  std::size_t hits = 0;
  for (std::size_t z = 1; z < 15; z += 3)
    for (std::size_t y = 1; y < 15; y += 3)
      for (std::size_t x = 1; x < 15; x += 3) {
        noisy(z, y, x) = rng() % 2 ? 65535 : 0;
        ++hits;
      }
  ASSERT_GT(hits, 100u);
  EXPECT_NE(noisy.values(), clean.values());
  EXPECT_EQ(median3(noisy).values(), clean.values());
}

TEST(Median3, RefusesNaN) {
  Volume<float> v({3, 3, 3});
  v(1, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(median3(v), DataError);
}

TEST(GaussianSmooth, EqualsTheGenericBlurAndRoundsIntegerScans) {
  std::mt19937 rng(5);
  Volume<float> f({9, 11, 13});
  for (auto& v : f.values()) v = float(rng() % 1000);
  Volume<std::uint16_t> u(f.shape());
  for (std::size_t i = 0; i < f.size(); ++i) u.values()[i] = static_cast<std::uint16_t>(f.values()[i]);
  for (double sigma : {0.4, 1.0}) {
    Volume<float> expect = f;
    gaussian_blur(expect, sigma);
    const Volume<float> got = gaussian_smooth(f, sigma);
    const Volume<std::uint16_t> got16 = gaussian_smooth(u, sigma);
    for (std::size_t i = 0; i < f.size(); ++i) {
      ASSERT_NEAR(got.values()[i], expect.values()[i], 1e-3) << i;
      ASSERT_LE(std::abs(got16.values()[i] - expect.values()[i]), 0.5 + 1e-3) << i;  // rounded to the grey step
    }
  }
  EXPECT_EQ(gaussian_smooth(u, 0.0).values(), u.values());
}
