// Grains damaged by the other scan's segmentation, explained by volume and centroid balance: a
// reference grain merged with a touching neighbour into one label, or cut into two labels, costed
// like a match, so that such a grain is lost rather than steal a neighbour's label.
#include "match_damage.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include "graintwin/core/geometry.hpp"
#include "graintwin/track/displacement_field.hpp"

namespace graintwin::track::detail {
namespace {

constexpr std::size_t none = DisplacementField::none;

/// A right match costs less than this 99.9 % of the time (chi^2 with 5 degrees of freedom).
constexpr double kRightMatchCost = 20.5;

/// Which grains on either side have a match about as good as a right one (below kRightMatchCost).
/// Such a label is not taken as a merged or cut one: a label that is grain i with a small
/// neighbour attached, or with a sliver cut off, is grain i's own match, not its damage. Such a
/// reference grain is not taken as having merged into a neighbour's label.
struct Plausible {
  std::vector<char> label, grain;
  explicit Plausible(const SparseCosts& c) : label(c.columns, 0), grain(c.rows(), 0) {
    for (std::size_t r = 0; r < c.rows(); ++r)
      for (std::size_t e = c.row_start[r]; e < c.row_start[r + 1]; ++e)
        if (c.cost[e] < kRightMatchCost) label[c.column[e]] = 1, grain[r] = 1;
  }
};

/// One explanation of a reference grain as damaged by the other scan's segmentation.
struct Damage {
  double cost = 0.0;
  std::size_t grain = none;
  std::size_t merged_with = none;                ///< the reference neighbour of a merge
  std::array<std::size_t, 2> label{none, none};  ///< the merged label, or the two pieces
  auto key() const { return std::tie(cost, grain, merged_with, label); }
};

/// Reference grain i's damage explanations as plausible as a right match (docs/shapes2tracks.md),
/// costed like a match: merged with a touching reference neighbour k into one label (its volume the
/// sum of theirs, its centroid their volume-weighted predicted centroid), or cut into two labels
/// (their volumes summing to i's, their volume-weighted centroid at i's prediction). Mass balance
/// ties such labels to grain i as closely as a right match would. Neither i, nor k, nor a label
/// may have a plausible match: the explanations stand in for matches that are implausible anyway.
/// The shape term of a match counts 1 (its mean): a damaged shape is not predicted.
void damage_explanations(std::size_t i, const ScanGrains& ref, const ScanGrains& def, const PointGrid& ref_grid,
                         const PointGrid& def_grid, const Prediction& at, const Scales& k, double largest_diameter,
                         const Plausible& plausible, std::vector<Damage>& out) {
  if (plausible.grain[i]) return;
  const Eigen::Vector3d& p = at.position[i];
  const double s2 = at.sigma[i] * at.sigma[i], v = ref.volume[i], d = equivalent_diameter(v);
  const auto consider = [&](double cost, std::size_t with, std::size_t a, std::size_t b) {
    if (cost + 1.0 < kRightMatchCost) out.push_back({cost + 1.0, i, with, {a, b}});
  };
  // Touching grains: centroids at most 0.75 (d_i + d_k) apart (elongated sand grains reach about
  // 0.75 d from their centroid).
  ref_grid.for_each_within(ref.centroid[i], 0.75 * (d + largest_diameter), [&](std::size_t n, double d2) {
    const double vn = ref.volume[n];
    if (n == i || plausible.grain[n] || d2 > std::pow(0.75 * (d + equivalent_diameter(vn)), 2)) return;
    const Eigen::Vector3d joint = (v * p + vn * at.position[n]) / (v + vn);
    def_grid.for_each_within(joint, at.window[i], [&](std::size_t m, double e2) {
      if (plausible.label[m]) return;
      const double zv = volume_z(def.volume[m], v + vn, k);
      consider(e2 / s2 + zv * zv, n, m, none);
    });
  });
  // Pieces: centroids inside the grain's body, found within its reach plus the prediction's spread.
  std::vector<std::size_t> piece;
  def_grid.for_each_within(p, std::min(at.window[i], 0.75 * d + 3.0 * at.sigma[i]), [&](std::size_t j, double) {
    if (def.volume[j] < v && !plausible.label[j]) piece.push_back(j);
  });
  for (std::size_t a = 0; a < piece.size(); ++a)
    for (std::size_t b = a + 1; b < piece.size(); ++b) {
      const double va = def.volume[piece[a]], vb = def.volume[piece[b]];
      const Eigen::Vector3d joint = (va * def.centroid[piece[a]] + vb * def.centroid[piece[b]]) / (va + vb);
      const double zv = volume_z(va + vb, v, k);
      consider((joint - p).squaredNorm() / s2 + zv * zv, none, piece[a], piece[b]);
    }
}

}  // namespace

std::vector<double> damage_lost_costs(const ScanGrains& ref, const ScanGrains& def, const PointGrid& ref_grid,
                                      const PointGrid& def_grid, const Prediction& at, const Scales& k,
                                      const SparseCosts& costs, double lost_cost) {
  const Plausible plausible(costs);
  const double largest_diameter = ref.size() ? equivalent_diameter(*std::max_element(ref.volume.begin(), ref.volume.end())) : 0.0;
  std::vector<std::vector<Damage>> found(ref.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t i = 0; i < ref.size(); ++i)
    damage_explanations(i, ref, def, ref_grid, def_grid, at, k, largest_diameter, plausible, found[i]);
  std::vector<Damage> all;
  for (const auto& f : found) all.insert(all.end(), f.begin(), f.end());
  std::sort(all.begin(), all.end(), [](const Damage& a, const Damage& b) { return a.key() < b.key(); });
  // A grain that fills at least 80 % of a merged label, or keeps at least 80 % of its volume in one
  // piece, is still that label's grain (ct2labels' accuracy criterion, IoU >= 0.8): it keeps its
  // lost cost and may match that label.
  const auto dominant = [](double part, double whole) { return part >= 0.8 * whole; };
  std::vector<double> lost(ref.size(), lost_cost);
  std::vector<char> explained(ref.size(), 0), used(def.size(), 0);
  for (const Damage& g : all) {
    const bool merge = g.merged_with != none;
    if (explained[g.grain] || (merge && explained[g.merged_with])) continue;
    if (std::any_of(g.label.begin(), g.label.end(), [&](std::size_t j) { return j != none && used[j]; })) continue;
    for (std::size_t j : g.label)
      if (j != none) used[j] = 1;
    explained[g.grain] = 1;
    if (merge) {
      explained[g.merged_with] = 1;
      const double v = ref.volume[g.grain], vn = ref.volume[g.merged_with];
      if (!dominant(v, v + vn)) lost[g.grain] = std::min(lost_cost, g.cost);
      if (!dominant(vn, v + vn)) lost[g.merged_with] = std::min(lost_cost, g.cost);
    } else {
      const double va = def.volume[g.label[0]], vb = def.volume[g.label[1]];
      if (!dominant(std::max(va, vb), va + vb)) lost[g.grain] = std::min(lost_cost, g.cost);
    }
  }
  return lost;
}

}  // namespace graintwin::track::detail
