// Marker watershed of -EDT: touching spheres split into the right grains, connectivity, masks,
// determinism across thread counts, and the whole chain on a noisy 128^3 scan of 512 spheres.
#include <gtest/gtest.h>
#include <omp.h>

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
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

using test::Ball;
using test::count_labels;
using test::paint_balls;

/// Jittered simple-cubic lattice of n^3 spheres, radius r (+-5 %), spacing `step`, jitter 0.15 r
/// (the anchors' throughput protocol).
std::vector<Ball> packing(int n, double r, double step, std::uint32_t seed) {
  return test::jittered_lattice(n, r, step, step / 2, 0.15 * r, 0.05, seed);
}

}  // namespace

TEST(Watershed, TwoOverlappingSpheresSplitAlongTheBisectingPlane) {
  // Radius 10 at x = 15 and x = 32: they overlap over 3 voxels, the bisecting plane is x = 23.5.
  const auto m = paint_balls({24, 24, 48}, {{11.5, 11.5, 15, 10}, {11.5, 11.5, 32, 10}});
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
  const auto m = paint_balls({52, 52, 52}, balls);
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
  const auto m = paint_balls({20, 20, 40}, {{10, 10, 9, 6}, {10, 10, 30, 6}});
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
  const auto grey = test::scan_balls({45, 45, 45}, balls, 9);
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

TEST(Watershed, ChainFindsEverySphereOfA128CubeScan) {
  // A realistic synthetic scan (blur and noise) of 512 jittered spheres; speed is measured by
  // bench/ct2labels_bench, not here.
  const auto balls = packing(8, 8.4, 16.0, 77);
  const auto grey = test::scan_balls({128, 128, 128}, balls, 3);
  const auto edt = distance_transform(binarise(grey, otsu_threshold(grey)));
  const HProposal h = propose_h(edt);
  const auto labels = watershed(edt, h_maxima_markers(edt, h.h_vox));
  EXPECT_EQ(count_labels(labels), balls.size());
}
