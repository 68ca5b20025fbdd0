// Markers from the EDT: h-maxima against brute-force reconstruction, known dynamics, peaks a
// minimum distance apart, and the automatic choice of h on sphere packings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <random>
#include <set>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/edt.hpp"
#include "graintwin/segment/markers.hpp"
#include "support/phantoms.hpp"
#include "graintwin/segment/watershed.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

/// h-maxima by definition: reconstruction by iterated geodesic dilation until stable, then the
/// plateaus of the result with no higher neighbour, labelled in raster order.
Volume<std::uint32_t> brute_h_maxima(const Volume<float>& f, float h, Connectivity c) {
  const Shape3 s = f.shape();
  const auto steps = neighbour_steps(c, s);
  const auto neighbours = [&](std::size_t p) {
    std::vector<std::size_t> out;
    const long x = p % s[2], y = (p / s[2]) % s[1], z = p / (s[2] * s[1]);
    for (const auto& st : steps) {
      const long zz = z + st.dz, yy = y + st.dy, xx = x + st.dx;
      if (zz < 0 || yy < 0 || xx < 0 || zz >= long(s[0]) || yy >= long(s[1]) || xx >= long(s[2])) continue;
      if (f(zz, yy, xx) > 0) out.push_back(f.index(zz, yy, xx));
    }
    return out;
  };
  std::vector<float> r(f.size());
  for (std::size_t p = 0; p < f.size(); ++p) r[p] = f.values()[p] - h;
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t p = 0; p < f.size(); ++p) {
      if (!(f.values()[p] > 0)) continue;
      float m = r[p];
      for (std::size_t q : neighbours(p)) m = std::max(m, r[q]);
      m = std::min(m, f.values()[p]);
      if (m != r[p]) r[p] = m, changed = true;
    }
  }
  Volume<std::uint32_t> labels(s);
  std::vector<std::uint8_t> seen(f.size(), 0);
  std::uint32_t k = 0;
  for (std::size_t p = 0; p < f.size(); ++p) {
    if (!(f.values()[p] > 0) || seen[p]) continue;
    std::vector<std::size_t> plateau{p}, stack{p};
    seen[p] = 1;
    bool is_max = true;
    while (!stack.empty()) {
      const std::size_t a = stack.back();
      stack.pop_back();
      for (std::size_t q : neighbours(a)) {
        if (r[q] > r[a]) is_max = false;
        if (r[q] == r[a] && !seen[q]) seen[q] = 1, stack.push_back(q), plateau.push_back(q);
      }
    }
    if (!is_max) continue;
    ++k;
    for (std::size_t q : plateau) labels.values()[q] = k;
  }
  return labels;
}

/// Dynamic of every regional maximum (labels of h_maxima_markers at h = 0), by definition: the
/// peak minus the best min-value path (max-min Dijkstra) to a higher voxel, or to an equal peak of
/// a lower label; the global maximum gets infinity. In units of f.
std::vector<double> brute_dynamics(const Volume<float>& f, const Volume<std::uint32_t>& maxima) {
  const Shape3 s = f.shape();
  const auto steps = neighbour_steps(Connectivity::corners, s);
  std::uint32_t k_max = 0;
  for (auto v : maxima.values()) k_max = std::max(k_max, v);
  std::vector<double> dyn;
  for (std::uint32_t k = 1; k <= k_max; ++k) {
    const std::size_t p0 = std::find(maxima.values().begin(), maxima.values().end(), k) - maxima.values().begin();
    const float peak = f.values()[p0];
    std::vector<float> best(f.size(), -1.0f);
    std::priority_queue<std::pair<float, std::size_t>> pq;
    pq.push({peak, p0});
    double saddle = -std::numeric_limits<double>::infinity();
    while (!pq.empty()) {
      const auto [v, p] = pq.top();
      pq.pop();
      if (v < best[p]) continue;
      const float fp = f.values()[p];
      if (fp > peak || (fp == peak && maxima.values()[p] != 0 && maxima.values()[p] < k)) {
        saddle = v;
        break;
      }
      const std::size_t x = p % s[2], y = p / s[2] % s[1], z = p / (s[2] * s[1]);
      for_each_neighbour(steps, s, z, y, x, p, [&](std::size_t q) {
        const float fq = f.values()[q];
        if (fq > 0 && std::min(v, fq) > best[q]) best[q] = std::min(v, fq), pq.push({best[q], q});
      });
    }
    dyn.push_back(peak - saddle);
  }
  return dyn;
}

using test::Ball;
using test::count_labels;

/// A simple-cubic lattice of n^3 touching spheres (radius r, spacing 2r - overlap), jittered.
std::vector<Ball> lattice(int n, double r, double overlap, double jitter, std::uint32_t seed) {
  return test::jittered_lattice(n, r, 2 * r - overlap, r + 1, jitter, 0.0, seed);
}

}  // namespace

TEST(HMaxima, MatchesBruteForceReconstructionOnRandomReliefs) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 6; ++trial) {
    // A random mask with a coarse random relief (few levels, so plateaus are common).
    Volume<float> f({7, 8, 9});
    for (auto& v : f.values()) v = rng() % 5 == 0 ? 0.0f : float(1 + rng() % 6);
    for (Connectivity c : {Connectivity::faces, Connectivity::edges, Connectivity::corners})
      for (double h : {0.0, 0.5, 1.0, 2.5}) {
        const auto got = h_maxima_markers(f, h, c);
        const auto expect = brute_h_maxima(f, float(h), c);
        ASSERT_EQ(got.values(), expect.values()) << "trial " << trial << " conn " << int(c) << " h " << h;
      }
  }
}

TEST(HMaxima, WatershedFromTheDynamicsAgreesWithTheMarkerWatershed) {
  // Random reliefs with few levels (plateaus and ties everywhere) and a sphere packing's EDT.
  std::mt19937 rng(23);
  std::vector<Volume<float>> reliefs;
  for (int trial = 0; trial < 6; ++trial) {
    Volume<float> f({7, 8, 9});
    for (auto& v : f.values()) v = rng() % 5 == 0 ? 0.0f : float(1 + rng() % 6);
    reliefs.push_back(std::move(f));
  }
  reliefs.push_back(distance_transform(test::paint_balls({30, 30, 30}, test::jittered_lattice(2, 7.0, 13.0, 8.0, 0.8, 0.1, 3))));
  for (std::size_t r = 0; r < reliefs.size(); ++r) {
    const auto& f = reliefs[r];
    for (Connectivity c : {Connectivity::faces, Connectivity::edges, Connectivity::corners}) {
      Volume<std::uint32_t> basins;
      const MaximaDynamics d = maxima_dynamics(f, c, &basins);
      ASSERT_EQ(count_labels(basins), d.peak.size());
      for (double h : {0.0, 0.5, 1.0, 1.7, 2.5}) {
        const auto markers = h_maxima_markers(f, h, c);
        const auto expect = watershed(f, markers, c);
        const auto got = watershed_from_dynamics(basins, d, h);
        ASSERT_EQ(count_labels(got), count_labels(expect)) << "relief " << r << " conn " << int(c) << " h " << h;
        // Exact on the markers: each plateau carries one label, a different one per marker.
        std::map<std::uint32_t, std::uint32_t> label_of_marker, marker_of_label;
        std::size_t agree = 0, solid = 0;
        for (std::size_t i = 0; i < f.size(); ++i) {
          ASSERT_EQ(got.values()[i] == 0, expect.values()[i] == 0);
          if (expect.values()[i] == 0) continue;
          ++solid;
          const std::uint32_t m = markers.values()[i];
          if (m != 0) {
            ASSERT_EQ(label_of_marker.emplace(m, got.values()[i]).first->second, got.values()[i]);
            ASSERT_EQ(marker_of_label.emplace(got.values()[i], m).first->second, m);
          }
        }
        // Below the plateaus only boundary voxels may differ: on the packing, almost none.
        std::map<std::uint32_t, std::uint32_t> got_of_expect;
        for (std::size_t i = 0; i < f.size(); ++i) {
          const std::uint32_t m = markers.values()[i];
          if (m != 0) got_of_expect[expect.values()[i]] = label_of_marker[m];
        }
        for (std::size_t i = 0; i < f.size(); ++i)
          if (expect.values()[i] != 0) agree += got_of_expect[expect.values()[i]] == got.values()[i];
        if (r + 1 == reliefs.size()) EXPECT_GE(double(agree), 0.99 * double(solid)) << "conn " << int(c) << " h " << h;
      }
    }
  }
}

TEST(HMaxima, MatchesBruteForceOnAnisotropicBlobEdt) {
  std::mt19937 rng(4);
  std::vector<Ball> blobs;
  for (int i = 0; i < 7; ++i) blobs.push_back({double(rng() % 14), double(rng() % 16), double(rng() % 18), 2.0 + rng() % 4});
  const auto m = test::paint_balls({14, 16, 18}, blobs, {2e-5, 1.5e-5, 1e-5});
  const auto edt = distance_transform(m);
  for (double h : {0.0, 0.7, 2.0}) {
    const auto got = h_maxima_markers(edt, h);
    EXPECT_EQ(got.values(), brute_h_maxima(edt, float(h * 1e-5), Connectivity::corners).values()) << h;
    EXPECT_GT(count_labels(got), 0u);
  }
}

TEST(HMaxima, PeakSurvivesWhileItsDynamicExceedsH) {
  // Along x: a peak of 5 and a peak of 3 separated by a saddle of 1, so the lower peak's dynamic is 2.
  Volume<float> f({1, 1, 9}, {1.0, 1.0, 1.0});
  f.values() = {1, 3, 5, 3, 1, 2, 3, 2, 1};
  // Each marker is the top of its h-dome: the voxels with f >= peak - h around the peak.
  EXPECT_EQ(h_maxima_markers(f, 1.9).values(), (std::vector<std::uint32_t>{0, 0, 1, 0, 0, 2, 2, 2, 0}));
  EXPECT_EQ(h_maxima_markers(f, 2.1).values(), (std::vector<std::uint32_t>{0, 1, 1, 1, 0, 0, 0, 0, 0}));
  EXPECT_THROW(h_maxima_markers(f, -1.0), UsageError);
}

TEST(HMaxima, APieceLowerThanHIsOneMarker) {
  // Two solid pieces one background voxel apart; the right one lies entirely below h, so its
  // reconstruction is flat (max f - h = -0.1 everywhere) and the whole piece is one marker.
  Volume<float> f({1, 1, 7}, {1.0, 1.0, 1.0});
  f.values() = {0, 5, 0, 2.9f, 1, 2.8f, 0};
  const auto l = h_maxima_markers(f, 3.0);
  EXPECT_EQ(l.values(), (std::vector<std::uint32_t>{0, 1, 0, 2, 2, 2, 0}));
  EXPECT_EQ(l.values(), brute_h_maxima(f, 3.0f, Connectivity::corners).values());
}

TEST(PeakMarkers, KeepsPeaksAtLeastTheMinimumDistanceApart) {
  // Two overlapping spheres: centres 14 voxels apart.
  const auto m = test::paint_balls({24, 24, 40}, {{11.5, 11.5, 12, 9}, {11.5, 11.5, 26, 9}});
  const auto edt = distance_transform(m);
  const auto two = peak_markers(edt, 10.0);
  ASSERT_EQ(count_labels(two), 2u);
  // Labelled in raster order: the lower-x peak (same z, y) first.
  std::vector<std::size_t> where(3);
  for (std::size_t i = 0; i < two.size(); ++i)
    if (two.values()[i]) where[two.values()[i]] = i;
  EXPECT_LT(where[1], where[2]);
  EXPECT_NEAR(double(where[1] % 40), 12.0, 1.0);
  EXPECT_NEAR(double(where[2] % 40), 26.0, 1.0);
  EXPECT_EQ(count_labels(peak_markers(edt, 15.0)), 1u);
  // Every pair of peaks respects the distance, whatever it is.
  const auto many = peak_markers(edt, 3.0);
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < many.size(); ++i)
    if (many.values()[i]) idx.push_back(i);
  for (std::size_t a = 0; a < idx.size(); ++a)
    for (std::size_t b = a + 1; b < idx.size(); ++b) {
      const auto xyz = [&](std::size_t i) { return std::array<double, 3>{double(i / 960), double(i / 40 % 24), double(i % 40)}; };
      const auto p = xyz(idx[a]), q = xyz(idx[b]);
      EXPECT_GE(std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]), 3.0);
    }
}

TEST(ProposeH, FindsTheMarkerPlateauOfATouchingSpherePacking) {
  // 4^3 jittered spheres of radius 7 overlapping by 1.5 voxels (necks of radius ~3, so real maxima
  // have dynamics of about 4 voxels), each with three warts of radius 2.5 on its surface that make
  // spurious shallow maxima.
  const auto balls = lattice(4, 7.0, 1.5, 0.6, 2024);
  std::vector<Ball> all = balls;
  std::mt19937 rng(8);
  std::normal_distribution<double> g;
  for (const auto& b : balls)
    for (int w = 0; w < 3; ++w) {
      double d[3] = {g(rng), g(rng), g(rng)};
      const double n = std::hypot(d[0], d[1], d[2]);
      all.push_back({b.z + 7.5 * d[0] / n, b.y + 7.5 * d[1] / n, b.x + 7.5 * d[2] / n, 2.5});
    }
  const auto m = test::paint_balls({55, 55, 55}, all);
  const auto edt = distance_transform(m);
  const HProposal p = propose_h(edt);
  EXPECT_GT(p.regional_maxima, balls.size());  // the plain regional maxima over-segment
  EXPECT_EQ(p.markers, balls.size());
  EXPECT_TRUE(p.radius_estimated);
  EXPECT_NEAR(p.reference_radius_m, 7e-5, 1.5e-5);
  // By the brute-force dynamics, exactly one maximum per sphere is deeper than h.
  const auto dyn = brute_dynamics(edt, h_maxima_markers(edt, 0.0));
  EXPECT_EQ(dyn.size(), p.regional_maxima);
  EXPECT_EQ(std::size_t(std::count_if(dyn.begin(), dyn.end(), [&](double d) { return d > p.h_vox * 1e-5; })), balls.size());
  EXPECT_LE(p.plateau_lo_vox, p.h_vox);
  EXPECT_GE(p.plateau_hi_vox, p.h_vox);
  EXPECT_EQ(p.markers_at_lo, balls.size());
  EXPECT_EQ(count_labels(h_maxima_markers(edt, p.h_vox)), balls.size());
  // A given radius bounds the search from above.
  const HProposal given = propose_h(edt, 4e-5);
  EXPECT_FALSE(given.radius_estimated);
  EXPECT_LE(given.plateau_hi_vox, 2.0 + 1e-9);
  EXPECT_THROW(propose_h(edt, -1.0), UsageError);
}

TEST(ProposeH, CopesWithMasksWithoutSolidOrWithoutBackground) {
  // No background and a neutral border: every distance is +infinity, one flat maximum.
  Volume<std::uint8_t> full({6, 7, 8}, {1e-5, 1e-5, 1e-5}, {0, 0, 0}, 1);
  const auto inf = distance_transform(full);
  const HProposal p = propose_h(inf);
  EXPECT_TRUE(std::isfinite(p.h_vox));
  EXPECT_EQ(p.markers, 1u);
  const auto one = watershed(inf, h_maxima_markers(inf, p.h_vox));
  EXPECT_EQ(std::count(one.values().begin(), one.values().end(), 1u), long(one.size()));
  // No solid at all: nothing to mark.
  const auto none = distance_transform(Volume<std::uint8_t>({6, 7, 8}, {1e-5, 1e-5, 1e-5}));
  const HProposal q = propose_h(none);
  EXPECT_EQ(q.markers, 0u);
  EXPECT_EQ(q.regional_maxima, 0u);
  EXPECT_EQ(count_labels(h_maxima_markers(none, 1.0)), 0u);
}
