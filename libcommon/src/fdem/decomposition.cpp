#include "graintwin/fdem/decomposition.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {
namespace {

constexpr const char* kAxisNames[3] = {"x", "y", "z"};

int leaf(int rank) { return -rank - 1; }

int longest_axis(const Aabb& box) {
  const Eigen::Vector3d extent = box.hi - box.lo;
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (extent[k] > extent[axis]) axis = k;  // strict: ties keep the lower axis, on every rank alike
  return axis;
}

// Cuts grains[0, m) (sorted along the cut axis by the caller) after k of them: the k whose work
// prefix comes closest to `target`, moved off a run of equal coordinates so that the cut plane
// separates the two sides exactly as owner_rank will.
std::size_t cut_index(std::span<const double> coordinates, std::span<const double> prefix, double target) {
  const std::size_t m = coordinates.size();
  auto miss = [&](std::size_t k) { return std::abs(prefix[k] - target); };
  std::size_t best = 0;
  for (std::size_t k = 1; k <= m; ++k)
    if (miss(k) < miss(best)) best = k;
  std::size_t down = best, up = best;
  while (down > 0 && down < m && coordinates[down - 1] == coordinates[down]) --down;
  while (up > 0 && up < m && coordinates[up - 1] == coordinates[up]) ++up;
  return miss(up) < miss(down) ? up : down;
}

class Bisector {
 public:
  Bisector(std::span<const Eigen::Vector3d> centroids, std::span<const double> work, double min_thickness, Subdomains& out)
      : centroids_(centroids), work_(work), min_thickness_(min_thickness), out_(out) {}

  // Splits the grains of `grains` (their indices) in `box` over ranks [first_rank, first_rank +
  // ranks); returns the child reference of the subtree (a cut index or a leaf).
  int bisect(std::span<std::uint32_t> grains, const Aabb& box, int first_rank, int ranks) {
    if (ranks == 1) {
      out_.boxes[first_rank] = box;
      return leaf(first_rank);
    }
    const int axis = longest_axis(box);
    std::sort(grains.begin(), grains.end(), [&](std::uint32_t a, std::uint32_t b) {
      const double ca = centroids_[a][axis], cb = centroids_[b][axis];
      return ca < cb || (ca == cb && a < b);
    });
    const std::size_t m = grains.size();
    std::vector<double> coordinates(m), prefix(m + 1, 0.0);
    for (std::size_t i = 0; i < m; ++i) {
      coordinates[i] = centroids_[grains[i]][axis];
      prefix[i + 1] = prefix[i] + work_[grains[i]];
    }
    const int low_ranks = ranks / 2;
    double cut = box.lo[axis] + (box.hi[axis] - box.lo[axis]) * low_ranks / ranks;  // no grains: by volume
    std::size_t k = 0;
    if (m > 0) {
      k = cut_index(coordinates, prefix, prefix[m] * low_ranks / ranks);
      const double below = k == 0 ? box.lo[axis] : coordinates[k - 1];
      const double above = k == m ? box.hi[axis] : coordinates[k];
      cut = below + 0.5 * (above - below);
      if (!(cut > below)) cut = above;  // adjacent doubles: the upper one, still above every low grain
      // Work crowded at one side of the box (a platen pressing) would leave that side's box thinner
      // than a grain: the cut stops at the thinnest allowed, the best balance it permits.
      const double margin = min_thickness_ * (1 + 1e-9);  // the boxes' sides, differences of cuts, round off
      const double lowest = box.lo[axis] + margin, highest = box.hi[axis] - margin;
      if (lowest <= highest && (cut < lowest || cut > highest)) {
        cut = std::clamp(cut, lowest, highest);
        k = static_cast<std::size_t>(std::lower_bound(coordinates.begin(), coordinates.end(), cut) - coordinates.begin());
      }
    }
    const int node = static_cast<int>(out_.cuts.size());
    out_.cuts.push_back({axis, cut, 0, 0});
    Aabb low_box = box, high_box = box;
    low_box.hi[axis] = cut;
    high_box.lo[axis] = cut;
    const int low = bisect(grains.first(k), low_box, first_rank, low_ranks);
    const int high = bisect(grains.subspan(k), high_box, first_rank + low_ranks, ranks - low_ranks);
    out_.cuts[node].low = low;
    out_.cuts[node].high = high;
    return node;
  }

 private:
  std::span<const Eigen::Vector3d> centroids_;
  std::span<const double> work_;
  double min_thickness_;  ///< m, the thinnest a box may be across a cut
  Subdomains& out_;
};

Subdomains bisect_unchecked(std::span<const Eigen::Vector3d> centroids, std::span<const double> work,
                            const Aabb& domain, int ranks, double reach, double min_thickness) {
  Subdomains out;
  out.domain = domain;
  out.reach = reach;
  out.boxes.resize(ranks);
  out.cuts.reserve(ranks - 1);
  std::vector<std::uint32_t> grains(centroids.size());
  std::iota(grains.begin(), grains.end(), 0u);
  Bisector(centroids, work, min_thickness, out).bisect(grains, domain, 0, ranks);
  return out;
}

struct ThinSide {
  int rank = 0, axis = 0;
  double thickness = 0;  ///< m
};

// The thinnest side of a subdomain across a cut (a side the whole domain spans was never cut)
// when it is thinner than `min_thickness`.
std::optional<ThinSide> thinnest_cut_side(const Subdomains& subdomains, double min_thickness) {
  std::optional<ThinSide> thinnest;
  for (int r = 0; r < subdomains.ranks(); ++r) {
    const Aabb& box = subdomains.boxes[r];
    for (int axis = 0; axis < 3; ++axis) {
      const bool cut = box.lo[axis] != subdomains.domain.lo[axis] || box.hi[axis] != subdomains.domain.hi[axis];
      const double thickness = box.hi[axis] - box.lo[axis];
      if (cut && thickness < min_thickness && (!thinnest || thickness < thinnest->thickness))
        thinnest = ThinSide{r, axis, thickness};
    }
  }
  return thinnest;
}

void check_inputs(std::span<const Eigen::Vector3d> centroids, std::span<const double> bounding_radii,
                  std::span<const double> work, const Aabb& domain, int ranks, double skin) {
  if (ranks < 1) throw UsageError(fmt::format("the domain decomposition needs at least one rank (got {})", ranks));
  if (bounding_radii.size() != centroids.size() || work.size() != centroids.size())
    throw UsageError(fmt::format("the domain decomposition needs one bounding radius and one work weight per grain "
                                 "(got {} centroids, {} radii, {} weights)",
                                 centroids.size(), bounding_radii.size(), work.size()));
  if (!(skin >= 0) || !std::isfinite(skin))
    throw UsageError(fmt::format("the contact skin must be finite and >= 0 (got {} m)", skin));
  if (!domain.lo.allFinite() || !domain.hi.allFinite() || !(domain.lo.array() < domain.hi.array()).all())
    throw UsageError(fmt::format("the sample's box ({}, {}, {}) to ({}, {}, {}) m is empty or not finite: give the "
                                 "box of the platens and the membrane",
                                 domain.lo.x(), domain.lo.y(), domain.lo.z(), domain.hi.x(), domain.hi.y(),
                                 domain.hi.z()));
  for (std::size_t i = 0; i < centroids.size(); ++i) {
    const Eigen::Vector3d& c = centroids[i];
    if (!domain.contains(c))  // false for a non-finite centroid too
      throw UsageError(fmt::format("grain {}'s centroid ({}, {}, {}) m is not inside the sample's box ({}, {}, {}) to "
                                   "({}, {}, {}) m: decompose a box that holds every grain",
                                   i, c.x(), c.y(), c.z(), domain.lo.x(), domain.lo.y(), domain.lo.z(),
                                   domain.hi.x(), domain.hi.y(), domain.hi.z()));
    if (!(bounding_radii[i] >= 0) || !std::isfinite(bounding_radii[i]))
      throw UsageError(fmt::format("grain {}'s bounding radius must be finite and >= 0 (got {} m)", i, bounding_radii[i]));
    if (!(work[i] > 0) || !std::isfinite(work[i]))
      throw UsageError(fmt::format("grain {}'s work weight must be finite and > 0 (got {}): weigh every grain by its "
                                   "measured cost",
                                   i, work[i]));
  }
}

}  // namespace

Subdomains bisect_domain(std::span<const Eigen::Vector3d> centroids, std::span<const double> bounding_radii,
                         std::span<const double> work, const Aabb& domain, int ranks, double skin) {
  check_inputs(centroids, bounding_radii, work, domain, ranks, skin);
  const double largest_radius =
      bounding_radii.empty() ? 0.0 : *std::max_element(bounding_radii.begin(), bounding_radii.end());
  const double reach = largest_radius + skin;
  const double min_thickness = 2.0 * largest_radius + skin;
  Subdomains subdomains = bisect_unchecked(centroids, work, domain, ranks, reach, min_thickness);
  const std::optional<ThinSide> thin = thinnest_cut_side(subdomains, min_thickness);
  if (!thin) return subdomains;
  // One rank never cuts, so the search ends; it is short, since too thin means few grains per rank.
  int fitting = ranks - 1;
  while (fitting > 1 && thinnest_cut_side(bisect_unchecked(centroids, work, domain, fitting, reach, min_thickness), min_thickness))
    --fitting;
  throw UsageError(fmt::format(
      "{} ranks cut the sample into subdomains as thin as {:.4g} m along {} (rank {}), less than the largest grain's "
      "diameter plus the contact skin ({:.4g} + {:.4g} m): run on at most {} ranks",
      ranks, thin->thickness, kAxisNames[thin->axis], thin->rank, 2.0 * largest_radius, skin, fitting));
}

int owner_rank(const Subdomains& subdomains, const Eigen::Vector3d& point) {
  if (subdomains.cuts.empty()) return 0;
  int node = 0;
  for (;;) {
    const BisectionCut& c = subdomains.cuts[node];
    const int next = point[c.axis] < c.cut ? c.low : c.high;
    if (next < 0) return -next - 1;
    node = next;
  }
}

std::vector<int> owner_ranks(const Subdomains& subdomains, std::span<const Eigen::Vector3d> centroids) {
  std::vector<int> owners(centroids.size());
  for (std::size_t i = 0; i < centroids.size(); ++i) owners[i] = owner_rank(subdomains, centroids[i]);
  return owners;
}

Aabb reach_box(const Subdomains& subdomains, int rank) {
  Aabb box = subdomains.boxes.at(rank);
  constexpr double kFar = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (box.lo[k] == subdomains.domain.lo[k]) box.lo[k] = -kFar;
    if (box.hi[k] == subdomains.domain.hi[k]) box.hi[k] = kFar;
  }
  return box;
}

std::vector<int> ghost_ranks(const Subdomains& subdomains, const Eigen::Vector3d& centre, double radius, int owner) {
  const double range = radius + subdomains.reach;
  std::vector<int> ranks;
  auto visit = [&](auto&& self, int child) -> void {
    if (child < 0) {
      const int rank = -child - 1;
      if (rank != owner && reach_box(subdomains, rank).squared_distance(centre) <= range * range) ranks.push_back(rank);
      return;
    }
    const BisectionCut& c = subdomains.cuts[child];
    if (centre[c.axis] - range <= c.cut) self(self, c.low);
    if (centre[c.axis] + range >= c.cut) self(self, c.high);
  };
  visit(visit, subdomains.cuts.empty() ? leaf(0) : 0);  // low subtrees first: they hold the lower ranks, so sorted
  return ranks;
}

std::vector<double> rank_loads(std::span<const int> owners, std::span<const double> work, int ranks) {
  if (owners.size() != work.size())
    throw UsageError(fmt::format("rank loads need one owner per work weight (got {} owners, {} weights)",
                                 owners.size(), work.size()));
  std::vector<double> loads(std::max(ranks, 0), 0.0);
  for (std::size_t i = 0; i < owners.size(); ++i) {
    if (owners[i] < 0 || owners[i] >= ranks)
      throw UsageError(fmt::format("grain {}'s owner rank {} is not one of the {} ranks", i, owners[i], ranks));
    loads[owners[i]] += work[i];
  }
  return loads;
}

double load_imbalance(std::span<const double> loads) {
  if (loads.empty()) return 0.0;
  const double mean = std::accumulate(loads.begin(), loads.end(), 0.0) / static_cast<double>(loads.size());
  if (!(mean > 0)) return 0.0;
  return *std::max_element(loads.begin(), loads.end()) / mean - 1.0;
}

bool needs_rebalance(std::span<const double> loads) { return load_imbalance(loads) > kRebalanceImbalance; }

void weigh_by_time(std::span<double> work, double seconds) {
  const double counted = std::accumulate(work.begin(), work.end(), 0.0);
  if (!(counted > 0) || !(seconds > 0)) return;
  const double nanoseconds_per_count = 1e9 * seconds / counted;
  for (double& w : work) w = std::round(w * nanoseconds_per_count);
}

}  // namespace graintwin::fdem
