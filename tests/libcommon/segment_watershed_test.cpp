// Marker watershed of -EDT: touching spheres split into the right grains, connectivity, masks,
// determinism across thread counts, and the throughput of the whole chain on a 128^3 packing.
#include <gtest/gtest.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/segment/denoise.hpp"
#include "graintwin/segment/edt.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/markers.hpp"
#include "graintwin/segment/threshold.hpp"
#include "graintwin/segment/watershed.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

struct Ball {
  double z, y, x, r;
};

Volume<std::uint8_t> paint(Shape3 shape, const std::vector<Ball>& balls, Vec3 voxel = {1e-5, 1e-5, 1e-5}) {
  Volume<std::uint8_t> m(shape, voxel);
  for (const Ball& b : balls)
    for (long z = std::max(0L, long(b.z - b.r)); z <= std::min(long(shape[0]) - 1, long(b.z + b.r) + 1); ++z)
      for (long y = std::max(0L, long(b.y - b.r)); y <= std::min(long(shape[1]) - 1, long(b.y + b.r) + 1); ++y)
        for (long x = std::max(0L, long(b.x - b.r)); x <= std::min(long(shape[2]) - 1, long(b.x + b.r) + 1); ++x)
          if (std::hypot(z - b.z, y - b.y, x - b.x) <= b.r) m(z, y, x) = 1;
  return m;
}

/// Jittered simple-cubic lattice of n^3 spheres, radius r (+-5 %), spacing `step`, jitter 0.15 r
/// (the anchors' throughput protocol).
std::vector<Ball> packing(int n, double r, double step, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const auto u = [&] { return (rng() % 20001) / 10000.0 - 1.0; };
  std::vector<Ball> b;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        b.push_back({step * (i + 0.5) + 0.15 * r * u(), step * (j + 0.5) + 0.15 * r * u(),
                     step * (k + 0.5) + 0.15 * r * u(), r * (1.0 + 0.05 * u())});
  return b;
}

/// A synthetic scan of the balls: 2x2x2 supersampled occupancy, grey 0.25 + 0.5 occupancy,
/// Gaussian blur 0.8 voxel, Gaussian noise 0.03 (the spam / kalisphera protocol).
Volume<float> scan(Shape3 shape, const std::vector<Ball>& balls, std::uint32_t seed) {
  Volume<float> occ(shape, {1e-5, 1e-5, 1e-5});
  for (const Ball& b : balls)
    for (long z = std::max(0L, long(b.z - b.r) - 1); z <= std::min(long(shape[0]) - 1, long(b.z + b.r) + 1); ++z)
      for (long y = std::max(0L, long(b.y - b.r) - 1); y <= std::min(long(shape[1]) - 1, long(b.y + b.r) + 1); ++y)
        for (long x = std::max(0L, long(b.x - b.r) - 1); x <= std::min(long(shape[2]) - 1, long(b.x + b.r) + 1); ++x) {
          int in = 0;
          for (double a : {-0.25, 0.25})
            for (double c : {-0.25, 0.25})
              for (double d : {-0.25, 0.25}) in += std::hypot(z + a - b.z, y + c - b.y, x + d - b.x) <= b.r;
          occ(z, y, x) = std::min(1.0f, occ(z, y, x) + in / 8.0f);
        }
  for (float& v : occ.values()) v = 0.25f + 0.5f * v;
  gaussian_blur(occ, 0.8);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.03f);
  for (float& v : occ.values()) v += noise(rng);
  return occ;
}

std::size_t count_labels(const Volume<std::uint32_t>& l) {
  std::set<std::uint32_t> s(l.values().begin(), l.values().end());
  s.erase(0);
  return s.size();
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(Watershed, TwoOverlappingSpheresSplitAlongTheBisectingPlane) {
  // Radius 10 at x = 15 and x = 32: they overlap over 3 voxels, the bisecting plane is x = 23.5.
  const auto m = paint({24, 24, 48}, {{11.5, 11.5, 15, 10}, {11.5, 11.5, 32, 10}});
  const auto edt = distance_transform(m);
  const auto markers = h_maxima_markers(edt, 1.0);
  ASSERT_EQ(count_labels(markers), 2u);
  const auto labels = watershed(edt, markers);
  ASSERT_EQ(count_labels(labels), 2u);
  std::size_t per_side[2][3] = {};
  for (std::size_t z = 0; z < 24; ++z)
    for (std::size_t y = 0; y < 24; ++y)
      for (std::size_t x = 0; x < 48; ++x) {
        ASSERT_EQ(labels(z, y, x) != 0, m(z, y, x) != 0);  // every mask voxel labelled, nothing else
        if (m(z, y, x)) ++per_side[x > 23][labels(z, y, x)];
      }
  // Label 1 is the marker first in raster order: the sphere at lower x. Nothing crosses the plane.
  EXPECT_EQ(per_side[0][2], 0u);
  EXPECT_EQ(per_side[1][1], 0u);
  EXPECT_EQ(per_side[0][1], per_side[1][2]);  // mirror images
}

TEST(Watershed, LatticeOfTouchingSpheresGivesOneLabelPerSphere) {
  const auto balls = packing(4, 7.0, 13.0, 31);
  const auto m = paint({52, 52, 52}, balls);
  const auto edt = distance_transform(m);
  const HProposal h = propose_h(edt);
  const auto labels = watershed(edt, h_maxima_markers(edt, h.h_vox));
  ASSERT_EQ(count_labels(labels), balls.size());
  // Each label is the sphere holding most of its voxels, and each sphere has one label.
  std::map<std::uint32_t, std::map<std::size_t, std::size_t>> votes;
  for (std::size_t z = 0; z < 52; ++z)
    for (std::size_t y = 0; y < 52; ++y)
      for (std::size_t x = 0; x < 52; ++x) {
        const std::uint32_t l = labels(z, y, x);
        if (!l) continue;
        std::size_t nearest = 0;
        double best = 1e9;
        for (std::size_t i = 0; i < balls.size(); ++i) {
          const double d = std::hypot(z - balls[i].z, y - balls[i].y, x - balls[i].x) - balls[i].r;
          if (d < best) best = d, nearest = i;
        }
        ++votes[l][nearest];
      }
  std::set<std::size_t> owners;
  for (const auto& [l, v] : votes) {
    std::size_t total = 0, top = 0, owner = 0;
    for (const auto& [i, n] : v) {
      total += n;
      if (n > top) top = n, owner = i;
    }
    owners.insert(owner);
    EXPECT_GT(double(top) / total, 0.97) << "label " << l;
  }
  EXPECT_EQ(owners.size(), balls.size());
}

TEST(Watershed, ConnectivityDecidesWhetherDiagonalNeighboursFlood) {
  // A staircase touching only at corners, one with steps sharing edges; the marker at one end.
  Volume<std::uint8_t> corners({6, 6, 6}, {1, 1, 1}), edges({6, 6, 6}, {1, 1, 1});
  for (std::size_t i = 0; i < 6; ++i) corners(i, i, i) = 1, edges(0, i, i) = 1;
  for (const auto* m : {&corners, &edges}) {
    const auto edt = distance_transform(*m, true);
    Volume<std::uint32_t> marker(m->shape());
    marker(0, 0, 0) = 7;
    const auto l6 = watershed(edt, marker, Connectivity::faces);
    const auto l18 = watershed(edt, marker, Connectivity::edges);
    const auto l26 = watershed(edt, marker, Connectivity::corners);
    const auto n = [](const Volume<std::uint32_t>& l) { return std::count(l.values().begin(), l.values().end(), 7u); };
    EXPECT_EQ(n(l6), 1);
    EXPECT_EQ(n(l18), m == &corners ? 1 : 6);
    EXPECT_EQ(n(l26), 6);
  }
}

TEST(Watershed, KeepsOutsideTheMaskAndLeavesUnreachedComponentsEmpty) {
  // Two separate balls, a marker in one of them and a marker on the background.
  const auto m = paint({20, 20, 40}, {{10, 10, 9, 6}, {10, 10, 30, 6}});
  const auto edt = distance_transform(m);
  Volume<std::uint32_t> markers(m.shape());
  markers(10, 10, 9) = 1;
  markers(0, 0, 0) = 2;
  const auto labels = watershed(edt, markers);
  for (std::size_t i = 0; i < m.size(); ++i) {
    const bool left = i % 40 < 20;
    EXPECT_EQ(labels.values()[i], m.values()[i] && left ? 1u : 0u);
  }
  EXPECT_THROW(watershed(edt, Volume<std::uint32_t>({2, 2, 2})), UsageError);
  Volume<std::uint32_t> too_large(m.shape());
  too_large(10, 10, 9) = 0x80000000u;
  EXPECT_THROW(watershed(edt, too_large), UsageError);
}

TEST(Watershed, SameResultsWithOneAndTwoThreads) {
  const auto balls = packing(3, 8.0, 15.0, 5);
  const auto grey = scan({45, 45, 45}, balls, 9);
  struct Run {
    Volume<float> denoised;
    Volume<std::uint32_t> peaks, labels;
    std::vector<GrainRecord> table;
  };
  const auto run = [&](int threads) {
    omp_set_num_threads(threads);
    Run r;
    r.denoised = median3(grey);
    const auto mask = binarise(r.denoised, otsu_threshold(r.denoised));
    const auto edt = distance_transform(mask);
    r.peaks = peak_markers(edt, 4.0);
    const HProposal h = propose_h(edt);
    r.labels = watershed(edt, h_maxima_markers(edt, h.h_vox));
    remove_small_fragments(r.labels, 300);
    relabel_sequential(r.labels);
    r.table = grain_table(r.labels);
    return r;
  };
  const Run one = run(1);
  const Run two = run(2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(count_labels(one.labels), balls.size());
  EXPECT_EQ(one.denoised.values(), two.denoised.values());
  EXPECT_EQ(one.peaks.values(), two.peaks.values());
  EXPECT_EQ(one.labels.values(), two.labels.values());
  ASSERT_EQ(one.table.size(), two.table.size());
  for (std::size_t i = 0; i < one.table.size(); ++i) EXPECT_EQ(one.table[i].centroid_xyz, two.table[i].centroid_xyz);
}

TEST(Watershed, ChainThroughputOn128CubePacking) {
  // Not a benchmark: prints the speed of each stage so regressions are visible in the test log,
  // and checks that the chain finds every sphere of a realistic synthetic scan.
  const auto balls = packing(8, 8.4, 16.0, 77);
  const auto grey = scan({128, 128, 128}, balls, 3);
  const double mvox = 128.0 * 128 * 128 / 1e6;
  auto t = std::chrono::steady_clock::now();
  const auto mask = binarise(grey, otsu_threshold(grey));
  const double t_threshold = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const auto edt = distance_transform(mask);
  const double t_edt = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const HProposal h = propose_h(edt);
  const double t_h = seconds_since(t);
  t = std::chrono::steady_clock::now();
  auto markers = h_maxima_markers(edt, h.h_vox);
  const double t_markers = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const auto labels = watershed(edt, std::move(markers));
  const double t_ws = seconds_since(t);
  std::printf("128^3 chain, %d threads: threshold %.3f s, EDT %.3f s (%.0f Mvox/s), propose h %.3f s (h = %.2f vox), "
              "h-maxima %.3f s, watershed-26 %.3f s (%.0f Mvox/s)\n",
              omp_get_max_threads(), t_threshold, t_edt, mvox / t_edt, t_h, h.h_vox, t_markers, t_ws, mvox / t_ws);
  EXPECT_EQ(count_labels(labels), balls.size());
}
