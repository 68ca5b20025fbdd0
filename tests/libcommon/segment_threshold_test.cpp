// Otsu threshold, binarisation, hole filling and binary opening against exact answers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/threshold.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

template <class T>
Volume<T> two_level(T lo, T hi, std::size_t n_hi) {
  Volume<T> v({4, 5, 6}, {1.0, 1.0, 1.0}, {0, 0, 0}, lo);
  for (std::size_t i = 0; i < n_hi; ++i) v.values()[i * 7 % v.size()] = hi;
  return v;
}

Volume<std::uint8_t> ball(Shape3 shape, double cz, double cy, double cx, double r) {
  Volume<std::uint8_t> m(shape);
  for (std::size_t z = 0; z < shape[0]; ++z)
    for (std::size_t y = 0; y < shape[1]; ++y)
      for (std::size_t x = 0; x < shape[2]; ++x) m(z, y, x) = std::hypot(z - cz, y - cy, x - cx) <= r;
  return m;
}

std::size_t count(const Volume<std::uint8_t>& m) { return std::count(m.values().begin(), m.values().end(), 1); }

}  // namespace

TEST(Otsu, TwoLevelImageIsCutHalfWayBetweenTheLevels) {
  EXPECT_DOUBLE_EQ(otsu_threshold(two_level<std::uint8_t>(10, 200, 40)), 105.0);
  EXPECT_DOUBLE_EQ(otsu_threshold(two_level<std::uint16_t>(1000, 30000, 13)), 15500.0);
  const double t = otsu_threshold(two_level<float>(0.25f, 0.75f, 70));
  EXPECT_NEAR(t, 0.5, 1e-12);
  const auto mask = binarise(two_level<float>(0.25f, 0.75f, 70), t);
  EXPECT_EQ(count(mask), 70u);
}

TEST(Otsu, HistogramEdgeMatchesAnExhaustiveSearch) {
  // Skewed bimodal histograms, overlapping or separated by empty bins: the returned edge must be
  // the middle of the range of edges with the largest between-class variance.
  for (std::size_t second : {22u, 38u}) {
    std::vector<std::uint64_t> h(64, 0);
    std::mt19937 rng(3);
    for (int i = 0; i < 5000; ++i) ++h[std::min<std::size_t>(63, 10 + rng() % 9 + rng() % 9)];
    for (int i = 0; i < 1500; ++i) ++h[std::min<std::size_t>(63, second + rng() % 13 + rng() % 7)];
    double best = -1.0;
    std::size_t first_k = 0, last_k = 0;
    for (std::size_t k = 1; k < h.size(); ++k) {
      double w0 = 0, w1 = 0, m0 = 0, m1 = 0;
      for (std::size_t i = 0; i < h.size(); ++i) (i < k ? w0 : w1) += h[i], (i < k ? m0 : m1) += double(h[i]) * i;
      if (w0 == 0 || w1 == 0) continue;
      const double var = w0 * w1 * std::pow(m0 / w0 - m1 / w1, 2);
      if (var > best * (1 + 1e-12)) {
        best = var, first_k = last_k = k;
      } else if (var >= best * (1 - 1e-12) && last_k + 1 == k) {
        last_k = k;
      }
    }
    EXPECT_DOUBLE_EQ(otsu_bin_edge(h), 0.5 * double(first_k + last_k)) << "second mode at " << second;
    if (second == 38u) {
      EXPECT_GT(last_k, first_k);  // the separated case does have a tie
    }
  }
}

TEST(Otsu, NoisyFloatScanSplitsGrainFromVoid) {
  // 30 % grain at 0.75, void at 0.25, Gaussian noise 0.05: the threshold lies near 0.5 and the
  // mask recovers the grain voxels with few errors.
  Volume<float> v({20, 20, 20});
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  std::vector<std::uint8_t> truth(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    truth[i] = i % 10 < 3;
    v.values()[i] = (truth[i] ? 0.75f : 0.25f) + noise(rng);
  }
  const double t = otsu_threshold(v);
  EXPECT_NEAR(t, 0.5, 0.03);
  const auto m = binarise(v, t);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < v.size(); ++i) wrong += m.values()[i] != truth[i];
  EXPECT_LT(wrong, v.size() / 1000);
}

TEST(Otsu, ConstantImageIsRefusedWithAHint) {
  Volume<std::uint16_t> v({3, 3, 3}, {1.0, 1.0, 1.0}, {0, 0, 0}, 777);
  try {
    otsu_threshold(v);
    FAIL() << "no exception";
  } catch (const DataError& e) {
    EXPECT_EQ(e.message(), "Otsu is undefined for a constant image; give --threshold");
  }
  EXPECT_THROW(otsu_threshold(Volume<float>({2, 2, 2}, {1.0, 1.0, 1.0}, {0, 0, 0}, 0.3f)), DataError);
  EXPECT_THROW(otsu_threshold(Volume<std::uint8_t>()), DataError);
}

TEST(Otsu, NaNIsRefusedWithItsCount) {
  auto v = two_level<float>(0.1f, 0.9f, 10);
  v.values()[3] = v.values()[17] = v.values()[50] = std::numeric_limits<float>::quiet_NaN();
  try {
    otsu_threshold(v);
    FAIL() << "no exception";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("holds 3 NaN values"), std::string::npos) << e.message();
  }
  v.values()[3] = v.values()[17] = v.values()[50] = 0.5f;
  v.values()[8] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(otsu_threshold(v), DataError);
}

TEST(Binarise, SolidIsStrictlyAboveTheThreshold) {
  Volume<std::uint8_t> v({1, 1, 4});
  v.values() = {9, 10, 11, 255};
  const auto m = binarise(v, 10.0);
  EXPECT_EQ(m.values(), (std::vector<std::uint8_t>{0, 0, 1, 1}));
}

TEST(FillHoles, FillsEnclosedCavitiesOnly) {
  // A ball with a closed inner cavity and an open channel to the volume face.
  auto m = ball({21, 21, 21}, 10, 10, 10, 8);
  const std::size_t full = count(m);
  for (std::size_t z = 0; z < 21; ++z)
    for (std::size_t y = 0; y < 21; ++y)
      for (std::size_t x = 0; x < 21; ++x)
        if (std::hypot(z - 10.0, y - 10.0, x - 10.0) <= 3.0) m(z, y, x) = 0;
  for (std::size_t x = 0; x <= 14; ++x) m(10, 16, x) = 0;  // a tunnel from the face into the ball
  const std::size_t tunnel = full - count(m) - 123;        // 123 voxels in the radius-3 cavity
  fill_holes(m);
  EXPECT_EQ(count(m), full - tunnel);
  EXPECT_EQ(m(10, 10, 10), 1);
  EXPECT_EQ(m(10, 16, 5), 0);
  // Background touching only a face through the face layer stays background.
  Volume<std::uint8_t> shell({5, 5, 5}, {1, 1, 1}, {0, 0, 0}, 1);
  shell(2, 2, 2) = 0;
  shell(0, 2, 2) = 0;
  fill_holes(shell);
  EXPECT_EQ(shell(2, 2, 2), 1);
  EXPECT_EQ(shell(0, 2, 2), 0);
}

TEST(FillHoles, MatchesACoordinateFloodOnRandomMasks) {
  // fill_holes steps by linear index and relies on wrapped steps landing on settled face voxels;
  // a flood with explicit coordinates on uneven shapes checks that reasoning.
  std::mt19937 rng(11);
  for (const Shape3 shape : {Shape3{7, 9, 11}, Shape3{1, 6, 5}, Shape3{12, 3, 8}, Shape3{5, 5, 1}}) {
    for (double solid : {0.55, 0.7, 0.85}) {
      Volume<std::uint8_t> m(shape);
      for (auto& v : m.values()) v = std::uniform_real_distribution<double>(0, 1)(rng) < solid ? 1 : 0;
      Volume<std::uint8_t> expect = m;
      std::vector<std::array<long, 3>> stack;
      const long nz = long(shape[0]), ny = long(shape[1]), nx = long(shape[2]);
      const auto push = [&](long z, long y, long x) {
        if (z < 0 || y < 0 || x < 0 || z >= nz || y >= ny || x >= nx || expect(z, y, x) != 0) return;
        expect(z, y, x) = 2;
        stack.push_back({z, y, x});
      };
      for (long z = 0; z < nz; ++z)
        for (long y = 0; y < ny; ++y)
          for (long x = 0; x < nx; ++x)
            if (z == 0 || y == 0 || x == 0 || z == nz - 1 || y == ny - 1 || x == nx - 1) push(z, y, x);
      while (!stack.empty()) {
        const auto [z, y, x] = stack.back();
        stack.pop_back();
        push(z - 1, y, x), push(z + 1, y, x), push(z, y - 1, x), push(z, y + 1, x), push(z, y, x - 1), push(z, y, x + 1);
      }
      for (auto& v : expect.values()) v = v == 2 ? 0 : 1;
      fill_holes(m);
      EXPECT_EQ(m.values(), expect.values()) << shape[0] << "x" << shape[1] << "x" << shape[2] << " solid " << solid;
    }
  }
}

TEST(BinaryOpen, MatchesBruteForceErosionThenDilation) {
  // Random blobs; the ball is every offset with |o|^2 <= r^2; outside the volume is neutral.
  std::mt19937 rng(5);
  Volume<std::uint8_t> m({12, 13, 14});
  for (int b = 0; b < 9; ++b) {
    const double cz = rng() % 12, cy = rng() % 13, cx = rng() % 14, r = 1.5 + (rng() % 30) / 10.0;
    const auto blob = ball(m.shape(), cz, cy, cx, r);
    for (std::size_t i = 0; i < m.size(); ++i) m.values()[i] |= blob.values()[i];
  }
  for (double r : {1.0, 1.5, 2.3}) {
    const int k = int(std::floor(r));
    const auto inside = [&](long z, long y, long x) { return z >= 0 && y >= 0 && x >= 0 && z < 12 && y < 13 && x < 14; };
    Volume<std::uint8_t> eroded(m.shape()), expect(m.shape());
    for (long z = 0; z < 12; ++z)
      for (long y = 0; y < 13; ++y)
        for (long x = 0; x < 14; ++x) {
          bool all = m(z, y, x);
          for (int a = -k; a <= k; ++a)
            for (int b = -k; b <= k; ++b)
              for (int c = -k; c <= k; ++c)
                if (a * a + b * b + c * c <= r * r && inside(z + a, y + b, x + c)) all = all && m(z + a, y + b, x + c);
          eroded(z, y, x) = all;
        }
    for (long z = 0; z < 12; ++z)
      for (long y = 0; y < 13; ++y)
        for (long x = 0; x < 14; ++x) {
          bool any = false;
          for (int a = -k; a <= k; ++a)
            for (int b = -k; b <= k; ++b)
              for (int c = -k; c <= k; ++c)
                if (a * a + b * b + c * c <= r * r && inside(z + a, y + b, x + c)) any = any || eroded(z + a, y + b, x + c);
          expect(z, y, x) = any;
        }
    auto opened = m;
    binary_open(opened, r);
    EXPECT_EQ(opened.values(), expect.values()) << "radius " << r;
    EXPECT_LT(count(opened), count(m));
  }
}

TEST(BinaryOpen, RemovesSpecksAndBridges) {
  auto m = ball({30, 30, 60}, 15, 15, 14, 9);
  const auto other = ball({30, 30, 60}, 15, 15, 45, 9);
  for (std::size_t i = 0; i < m.size(); ++i) m.values()[i] |= other.values()[i];
  auto clean = m;
  binary_open(clean, 2.0);
  for (std::size_t x = 14; x <= 45; ++x) m(15, 15, x) = 1;  // a one-voxel bridge
  m(2, 2, 2) = 1;                                            // a speck
  binary_open(m, 2.0);
  EXPECT_EQ(m(2, 2, 2), 0);
  EXPECT_EQ(m(15, 15, 30), 0);
  EXPECT_EQ(m.values(), clean.values());
  // A solid block touching the faces is not eroded from the outside.
  Volume<std::uint8_t> block({6, 6, 6}, {1, 1, 1}, {0, 0, 0}, 1);
  binary_open(block, 1.5);
  EXPECT_EQ(count(block), 216u);
}
