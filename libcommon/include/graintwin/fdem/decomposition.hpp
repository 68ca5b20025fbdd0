#pragma once
// Spatial domain decomposition of an FDEM sample over MPI ranks (docs/fdemrun.md, across machines): weighted recursive
// coordinate bisection (RCB) of the grains' centroids into axis-aligned boxes, one per rank, that
// tile the sample's box; which rank owns a point; which ranks must hold a ghost copy of a grain;
// the load imbalance and when to rebalance. Plain functions without MPI: every rank computes the
// same boxes from the same input (deterministic: sorts break ties by grain index, no threads),
// so ranks agree on owners without talking. Positions in m, (x, y, z); work in any one unit.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "graintwin/fdem/contact_geometry.hpp"

namespace graintwin::fdem {

/// Imbalance (max load / mean load - 1) above which the grains are bisected again.
inline constexpr double kRebalanceImbalance = 0.10;

/// One cut of the bisection tree. Points with coordinate < `cut` along `axis` go to `low`, the
/// others to `high`; a child >= 0 is another cut's index, a child < 0 is the leaf of rank -child - 1.
struct BisectionCut {
  int axis = 0;     ///< 0 x, 1 y, 2 z
  double cut = 0;   ///< m
  int low = -1, high = -1;
};

/// The subdomains of R ranks.
struct Subdomains {
  Aabb domain;                    ///< m, the sample's box the subdomains tile
  std::vector<Aabb> boxes;        ///< R boxes, rank r's is boxes[r]; each half-open [lo, hi) except on the domain's upper faces
  std::vector<BisectionCut> cuts; ///< R - 1 cuts, the root first (empty for one rank)
  /// m, how far from its own bounding sphere a grain reaches a partner in the worst case: the
  /// largest grain's bounding radius plus the contact skin (see ghost_ranks).
  double reach = 0;
  int ranks() const { return static_cast<int>(boxes.size()); }
};

/// Bisects the grains' centroids recursively into `ranks` subdomains of nearly equal work.
///
/// Inputs:
///   centroids       n grain centroids, m, all inside `domain`
///   bounding_radii  n radii, m, >= 0: a sphere about each centroid holding the whole grain
///   work            n per-grain work weights, > 0 (measured cost: nodes, elements, contacts)
///   domain          the sample's box (platens and membrane included), non-empty
///   ranks           R >= 1, any count: a box of r ranks is cut into floor(r/2) and ceil(r/2)
///                   ranks with the work split in that proportion
///   skin            m, >= 0, the contact model's Verlet skin
/// Returns the R boxes, the cut tree and the reach. Each cut is across the box's longest side, at
/// the gap between two centroids that comes closest to the proportional share of the work, so
/// every rank's work is within about one grain's work of the mean (w_max / 2 per level above it,
/// shared by the ranks below that level); but no nearer a side of the box than the largest grain's
/// diameter plus the skin, when the box is twice that thick (work crowded at one side then stays
/// out of balance).
/// Throws UsageError when ranks < 1, the inputs differ in length or hold a non-finite or
/// negative value, the domain is empty, a centroid lies outside it, or a subdomain comes out
/// thinner along a cut axis than the largest grain's diameter plus the skin (the message names
/// the largest rank count whose subdomains are thick enough).
Subdomains bisect_domain(std::span<const Eigen::Vector3d> centroids, std::span<const double> bounding_radii,
                         std::span<const double> work, const Aabb& domain, int ranks, double skin);

/// The rank whose box holds `point` (by the cut tree: log R comparisons). A point outside the
/// domain belongs to the nearest box across each cut, so every point has exactly one owner.
int owner_rank(const Subdomains& subdomains, const Eigen::Vector3d& point);

/// The owner rank of each centroid.
std::vector<int> owner_ranks(const Subdomains& subdomains, std::span<const Eigen::Vector3d> centroids);

/// Rank r's box as far as ownership goes: its faces on the domain's boundary pushed out to
/// infinity, since a centroid that left the domain belongs to the nearest box (owner_rank).
Aabb reach_box(const Subdomains& subdomains, int rank);

/// The ranks other than `owner` that must hold a ghost copy of a grain with bounding sphere
/// (centre, radius), sorted: those whose reach_box lies within radius + reach of the centre. Every
/// grain a rank owns has its centroid in the rank's reach_box (also after it left the domain) and
/// a radius <= reach - skin, so any partner within the skin of touching it is ghosted there, as
/// the broad phase needs.
std::vector<int> ghost_ranks(const Subdomains& subdomains, const Eigen::Vector3d& centre, double radius, int owner);

/// Per-rank sums of `work` over the grains each rank owns (owners[i] in [0, ranks)).
std::vector<double> rank_loads(std::span<const int> owners, std::span<const double> work, int ranks);

/// max load / mean load - 1: 0 when perfectly balanced (and when there is no work at all).
double load_imbalance(std::span<const double> loads);

/// Whether the imbalance exceeds kRebalanceImbalance, so the grains should be bisected again.
bool needs_rebalance(std::span<const double> loads);

/// Spreads `seconds` (s, the time one rank spent on its grains since the last balance check) over
/// `work` (per grain, the work that rank counted for it: contact checks, element work) in
/// proportion, as whole nanoseconds, so that sums over ranks are exact in any order. Counts alone
/// miss costs that differ from rank to rank (near-node lists built again where grains move fast, a
/// crowd at a platen); the time does not. No counted work, or no time: `work` unchanged.
void weigh_by_time(std::span<double> work, double seconds);

}  // namespace graintwin::fdem
