// fdem/decomposition: the recursive coordinate bisection of grains over ranks, owners, ghosts,
// imbalance and the refusal of subdomains too thin for a grain, against brute force.
#include "graintwin/fdem/decomposition.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "graintwin/core/error.hpp"
#include "support/errors.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

// A sand-sample-like box, 4 x 4 x 8 mm (z axial).
Aabb sample_box() { return {Eigen::Vector3d::Zero(), Eigen::Vector3d(4e-3, 4e-3, 8e-3)}; }

constexpr double kSkin = 0.02e-3;

struct Grains {
  std::vector<Eigen::Vector3d> centroids;
  std::vector<double> radii, work;
};

// n grains at random in the sample box: radii 0.05-0.15 mm, work 1-3 (a grain of more nodes costs more).
Grains random_grains(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Aabb box = sample_box();
  Grains g;
  for (std::size_t i = 0; i < n; ++i) {
    g.centroids.push_back(box.lo + (box.hi - box.lo).cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng))));
    g.radii.push_back(0.05e-3 + 0.1e-3 * unit(rng));
    g.work.push_back(1.0 + 2.0 * unit(rng));
  }
  return g;
}

Subdomains bisect(const Grains& g, int ranks, const Aabb& box = sample_box()) {
  return bisect_domain(g.centroids, g.radii, g.work, box, ranks, kSkin);
}

// Owner by scanning every box: [lo, hi) per axis, closed on the domain's upper faces.
int brute_force_owner(const Subdomains& s, const Eigen::Vector3d& p) {
  int found = -1;
  for (int r = 0; r < s.ranks(); ++r) {
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
      const Aabb& b = s.boxes[r];
      const bool below_hi = p[k] < b.hi[k] || (b.hi[k] == s.domain.hi[k] && p[k] == b.hi[k]);
      inside = inside && b.lo[k] <= p[k] && below_hi;
    }
    if (inside) {
      EXPECT_EQ(found, -1) << "two boxes hold (" << p.transpose() << ")";
      found = r;
    }
  }
  return found;
}

}  // namespace

TEST(Decomposition, BalancesWorkWithinOneGrainOnAnyRankCount) {
  const Grains g = random_grains(3000, 1);
  const double largest_work = *std::max_element(g.work.begin(), g.work.end());
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const Subdomains s = bisect(g, ranks);
    ASSERT_EQ(s.ranks(), ranks);
    EXPECT_EQ(s.cuts.size(), static_cast<std::size_t>(ranks - 1));
    const std::vector<double> loads = rank_loads(owner_ranks(s, g.centroids), g.work, ranks);
    const double mean = std::accumulate(loads.begin(), loads.end(), 0.0) / ranks;
    for (int r = 0; r < ranks; ++r)
      EXPECT_LE(std::abs(loads[r] - mean), largest_work) << ranks << " ranks, rank " << r;
    EXPECT_FALSE(needs_rebalance(loads)) << ranks << " ranks: imbalance " << load_imbalance(loads);
  }
}

TEST(Decomposition, BoxesTileTheDomain) {
  const Grains g = random_grains(2000, 2);
  const Aabb domain = sample_box();
  const double domain_volume = (domain.hi - domain.lo).prod();
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const Subdomains s = bisect(g, ranks);
    double volume = 0;
    for (int r = 0; r < ranks; ++r) {
      const Aabb& b = s.boxes[r];
      EXPECT_TRUE(domain.contains(b.lo) && domain.contains(b.hi)) << "rank " << r;
      volume += (b.hi - b.lo).prod();
      for (int q = r + 1; q < ranks; ++q) {
        const Eigen::Vector3d overlap = b.hi.cwiseMin(s.boxes[q].hi) - b.lo.cwiseMax(s.boxes[q].lo);
        EXPECT_TRUE((overlap.array() <= 0).any()) << "ranks " << r << " and " << q << " overlap";
      }
    }
    EXPECT_NEAR(volume, domain_volume, 1e-12 * domain_volume) << ranks << " ranks";
  }
}

TEST(Decomposition, OwnerOfAPointMatchesBruteForce) {
  const Grains g = random_grains(1500, 3);
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> unit(-0.1, 1.1);  // a tenth of the points outside the domain
  const Aabb domain = sample_box();
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const Subdomains s = bisect(g, ranks);
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 2000; ++i)
      points.push_back(domain.lo + (domain.hi - domain.lo).cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng))));
    for (const BisectionCut& c : s.cuts) {  // points exactly on a cut plane and on the domain's faces
      Eigen::Vector3d p = g.centroids[points.size() % g.centroids.size()];
      p[c.axis] = c.cut;
      points.push_back(p);
      points.push_back(domain.hi);
      points.push_back(domain.lo);
    }
    for (const Eigen::Vector3d& p : points) {
      // Outside the domain a point belongs to the box of the nearest point inside.
      const Eigen::Vector3d inside = p.cwiseMax(domain.lo).cwiseMin(domain.hi);
      EXPECT_EQ(owner_rank(s, p), brute_force_owner(s, inside)) << ranks << " ranks, point " << p.transpose();
    }
  }
}

TEST(Decomposition, GhostsReachEveryPartnerWithinTheSkin) {
  const Grains g = random_grains(1200, 4);
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const Subdomains s = bisect(g, ranks);
    EXPECT_DOUBLE_EQ(s.reach, *std::max_element(g.radii.begin(), g.radii.end()) + kSkin);
    const std::vector<int> owners = owner_ranks(s, g.centroids);
    std::vector<std::vector<int>> ghosts(g.centroids.size());
    for (std::size_t i = 0; i < g.centroids.size(); ++i) {
      ghosts[i] = ghost_ranks(s, g.centroids[i], g.radii[i], owners[i]);
      std::vector<int> expected;  // every other box within radius + reach, by a scan of all boxes
      const double range = g.radii[i] + s.reach;
      for (int r = 0; r < ranks; ++r)
        if (r != owners[i] && s.boxes[r].squared_distance(g.centroids[i]) <= range * range) expected.push_back(r);
      EXPECT_EQ(ghosts[i], expected) << ranks << " ranks, grain " << i;
    }
    // What ghosts are for: a pair that may touch before the skin is used up is seen by both owners.
    std::size_t split_pairs = 0;
    for (std::size_t a = 0; a < g.centroids.size(); ++a)
      for (std::size_t b = a + 1; b < g.centroids.size(); ++b) {
        if (owners[a] == owners[b] || (g.centroids[a] - g.centroids[b]).norm() > g.radii[a] + g.radii[b] + kSkin)
          continue;
        ++split_pairs;
        EXPECT_TRUE(std::binary_search(ghosts[a].begin(), ghosts[a].end(), owners[b])) << "grain " << a;
        EXPECT_TRUE(std::binary_search(ghosts[b].begin(), ghosts[b].end(), owners[a])) << "grain " << b;
      }
    if (ranks > 1) {
      EXPECT_GT(split_pairs, 0u) << "the scene must have pairs across subdomains";
    }
  }
}

TEST(Decomposition, IsTheSameForTheSameGrainsInAnyOrder) {
  Grains g = random_grains(1000, 5);
  const Subdomains first = bisect(g, 5), again = bisect(g, 5);
  std::vector<std::size_t> order(g.centroids.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(55));
  Grains shuffled;
  for (std::size_t i : order) {
    shuffled.centroids.push_back(g.centroids[i]);
    shuffled.radii.push_back(g.radii[i]);
    shuffled.work.push_back(g.work[i]);
  }
  const Subdomains reordered = bisect(shuffled, 5);
  for (const Subdomains* other : {&again, &reordered})
    for (int r = 0; r < 5; ++r) {  // bit for bit: every rank must find the same boxes
      EXPECT_EQ(std::memcmp(first.boxes[r].lo.data(), other->boxes[r].lo.data(), 3 * sizeof(double)), 0) << r;
      EXPECT_EQ(std::memcmp(first.boxes[r].hi.data(), other->boxes[r].hi.data(), 3 * sizeof(double)), 0) << r;
    }
}

TEST(Decomposition, CutsBetweenLayersOfEqualCoordinates) {
  // A lattice of 4 x 4 x 8 equal grains: a cut through a layer would split grains the cut plane
  // gives to one side, so the layers stay whole and the loads follow them.
  Grains g;
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        g.centroids.push_back(Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5) * 1e-3);
        g.radii.push_back(0.1e-3);
        g.work.push_back(1.0);
      }
  for (int ranks : {2, 4, 8}) {
    const std::vector<double> loads = rank_loads(owner_ranks(bisect(g, ranks), g.centroids), g.work, ranks);
    for (double load : loads) EXPECT_EQ(load, 128.0 / ranks) << ranks << " ranks";
  }
  for (int ranks : {3, 5, 6, 7}) {
    const std::vector<double> loads = rank_loads(owner_ranks(bisect(g, ranks), g.centroids), g.work, ranks);
    for (double load : loads) EXPECT_LE(std::abs(load - 128.0 / ranks), 16.0) << ranks << " ranks: one layer";
  }
}

TEST(Decomposition, RefusesSubdomainsThinnerThanAGrainAndTheSkin) {
  // 2 mm cube, grains up to 0.6 mm across: 0.62 mm per subdomain at least, so 3 cuts per axis at most.
  const Aabb cube{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(2e-3)};
  Grains g = random_grains(400, 6);
  for (Eigen::Vector3d& c : g.centroids) c = c.cwiseQuotient(sample_box().hi).cwiseProduct(cube.hi);
  g.radii.assign(g.radii.size(), 0.3e-3);
  const std::string message = test::message_of([&] { bisect(g, 64, cube); });
  EXPECT_NE(message.find("64 ranks cut the sample into subdomains as thin as"), std::string::npos) << message;
  EXPECT_NE(message.find("(0.0006 + 2e-05 m)"), std::string::npos) << message;
  const std::size_t at = message.find("run on at most ");
  ASSERT_NE(at, std::string::npos) << message;
  const int fitting = std::stoi(message.substr(at + 15));
  EXPECT_GE(fitting, 8);
  EXPECT_LT(fitting, 64);
  EXPECT_NO_THROW(bisect(g, fitting, cube)) << "the rank count the message names must work";
  EXPECT_THROW(bisect(g, fitting + 1, cube), UsageError);
}

TEST(Decomposition, RefusesBadInputsNamingTheValue) {
  const Grains g = random_grains(50, 7);
  EXPECT_NE(test::message_of([&] { bisect(g, 0); }).find("at least one rank (got 0)"), std::string::npos);
  Grains short_radii = g;
  short_radii.radii.pop_back();
  EXPECT_NE(test::message_of([&] { bisect(short_radii, 2); }).find("(got 50 centroids, 49 radii, 50 weights)"), std::string::npos);
  Grains outside = g;
  outside.centroids[17].z() = 9e-3;
  EXPECT_NE(test::message_of([&] { bisect(outside, 2); }).find("grain 17's centroid"), std::string::npos);
  outside.centroids[17].z() = std::nan("");
  EXPECT_NE(test::message_of([&] { bisect(outside, 2); }).find("grain 17's centroid"), std::string::npos);
  Grains idle = g;
  idle.work[3] = 0;
  EXPECT_NE(test::message_of([&] { bisect(idle, 2); }).find("grain 3's work weight must be finite and > 0 (got 0)"),
            std::string::npos);
  Grains negative = g;
  negative.radii[4] = -1e-3;
  EXPECT_NE(test::message_of([&] { bisect(negative, 2); }).find("grain 4's bounding radius"), std::string::npos);
  EXPECT_NE(test::message_of([&] { bisect_domain(g.centroids, g.radii, g.work, sample_box(), 2, -1.0); }).find("skin"),
            std::string::npos);
  const Aabb flat{Eigen::Vector3d::Zero(), Eigen::Vector3d(4e-3, 4e-3, 0.0)};
  EXPECT_NE(test::message_of([&] { bisect(g, 2, flat); }).find("is empty or not finite"), std::string::npos);
}

TEST(Decomposition, ImbalanceAndTheRebalanceRule) {
  EXPECT_DOUBLE_EQ(load_imbalance(std::vector<double>{2, 2, 2, 2}), 0.0);
  EXPECT_DOUBLE_EQ(load_imbalance(std::vector<double>{1.2, 1.0, 1.0, 0.8}), 0.2);
  EXPECT_EQ(load_imbalance(std::vector<double>{}), 0.0);
  EXPECT_EQ(load_imbalance(std::vector<double>{0, 0}), 0.0);
  EXPECT_TRUE(needs_rebalance(std::vector<double>{1.2, 1.0, 1.0, 0.8}));
  EXPECT_FALSE(needs_rebalance(std::vector<double>{1.05, 1.0, 1.0, 0.95}));
  const std::vector<int> owners{0, 1, 1, 2};
  const std::vector<double> work{1, 2, 3, 4};
  EXPECT_EQ(rank_loads(owners, work, 3), (std::vector<double>{1, 5, 4}));
  EXPECT_NE(test::message_of([&] { rank_loads(owners, work, 2); }).find("grain 3's owner rank 2 is not one of the 2 ranks"),
            std::string::npos);
}

TEST(Decomposition, WorkCrowdedAtOneSideStopsTheCutAtTheThinnestBoxAllowed) {
  // A platen pressing the top: the top 0.4 mm of grains carry nearly all the work, so the balanced
  // cut would leave the top box 0.3 mm thick, less than a grain plus the skin (0.62 mm). The cut
  // stops at that thickness instead of refusing, and the owners follow the cut.
  Grains g = random_grains(400, 8);
  g.radii.assign(g.radii.size(), 0.3e-3);
  for (std::size_t i = 0; i < g.work.size(); ++i) g.work[i] = g.centroids[i].z() > 7.6e-3 ? 1000.0 : 1.0;
  const Subdomains s = bisect(g, 2);
  const double min_thickness = 0.6e-3 + kSkin;
  ASSERT_EQ(s.cuts.size(), 1u);
  EXPECT_EQ(s.cuts[0].axis, 2);
  EXPECT_GE(s.boxes[1].hi.z() - s.boxes[1].lo.z(), min_thickness);
  EXPECT_LT(s.boxes[1].hi.z() - s.boxes[1].lo.z(), 1.001 * min_thickness) << "no thicker than it must be";
  for (std::size_t i = 0; i < g.centroids.size(); ++i)
    EXPECT_EQ(owner_rank(s, g.centroids[i]), g.centroids[i].z() < s.cuts[0].cut ? 0 : 1) << "grain " << i;
}

TEST(Decomposition, WorkWeighedByTimeSharesTheRanksSeconds) {
  std::vector<double> work{1, 3, 0, 4};
  weigh_by_time(work, 16e-9);  // 8 counts in 16 ns: 2 ns a count
  EXPECT_EQ(work, (std::vector<double>{2, 6, 0, 8}));
  std::vector<double> thirds{1, 1, 1};
  weigh_by_time(thirds, 1e-9);  // whole nanoseconds, so sums over ranks are exact in any order
  EXPECT_EQ(thirds, (std::vector<double>{0, 0, 0}));
  std::vector<double> counts{1, 2};
  weigh_by_time(counts, 0.0);
  EXPECT_EQ(counts, (std::vector<double>{1, 2})) << "no time measured: the counts stay";
  std::vector<double> idle{0, 0};
  weigh_by_time(idle, 1.0);
  EXPECT_EQ(idle, (std::vector<double>{0, 0})) << "no work counted: nothing to share";
}

TEST(Decomposition, GhostsReachPartnersOfGrainsThatLeftTheDomain) {
  // Thrown grains leave the sample's box; their owner is the nearest box (owner_rank), so a pair
  // that may touch out there must still be seen by both owners. Measured on fdemrun's 48 thrown
  // boxes on 4 ranks: a pair beyond the box's face was missed, and the run left the one-rank bits.
  const Grains g = random_grains(1200, 9);
  const Aabb box = sample_box();
  std::mt19937_64 rng(10);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int ranks = 2; ranks <= 7; ++ranks) {
    const Subdomains s = bisect(g, ranks);
    // Pairs of grains 0.2 mm apart in a shell up to 2 mm outside the box.
    std::size_t outside_pairs = 0;
    for (int i = 0; i < 4000; ++i) {
      const Eigen::Vector3d p = box.lo - Eigen::Vector3d::Constant(2e-3) +
                                (box.hi - box.lo + Eigen::Vector3d::Constant(4e-3)).cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
      const Eigen::Vector3d q = p + 0.2e-3 * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5).normalized();
      const int a = owner_rank(s, p), b = owner_rank(s, q);
      if (box.contains(p) || a == b) continue;
      ++outside_pairs;
      const std::vector<int> ghosts_a = ghost_ranks(s, p, 0.15e-3, a), ghosts_b = ghost_ranks(s, q, 0.15e-3, b);
      EXPECT_TRUE(std::binary_search(ghosts_a.begin(), ghosts_a.end(), b)) << ranks << " ranks, outside pair " << i;
      EXPECT_TRUE(std::binary_search(ghosts_b.begin(), ghosts_b.end(), a)) << ranks << " ranks, outside pair " << i;
    }
    EXPECT_GT(outside_pairs, 20u) << ranks << " ranks: the test needs pairs across owners outside the box";
  }
}
