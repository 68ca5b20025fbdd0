#pragma once
// Internal to the packer (packing.cpp): its candidate pairs, a Verlet list of the grains whose
// bounding spheres come within a skin of each other, found through core/point_grid and kept
// until the grains have moved or grown by half the skin.
#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "packing_geometry.hpp"

namespace graintwin::synth::detail {

// The packer's loops run in parallel only above these sizes: each parallel region costs a
// barrier, which on a busy machine (more threads than free cores) can cost a scheduler time
// slice, far more than the work of a small packing.
inline constexpr std::size_t kParallelPairs = 1000;
inline constexpr std::size_t kParallelGrains = 1000;

/// A candidate pair a < b, its last evaluation and what is known of its gap.
struct PairSlot {
  int a = 0, b = 0;
  PairEval eval;
  double travel_a = 0.0, travel_b = 0.0;  // travel counters when `bound` was taken
  double bound = -HUGE_VAL;               // lower bound of the gap at that time
};

class CandidatePairs {
 public:
  /// The list for positions x at common scale s: every pair i < j whose bounding spheres
  /// (radius s rmax) come within `skin` of each other, ordered by (i, j); each grain's pairs
  /// indexed for of().
  void build(const std::vector<Eigen::Vector3d>& x, const std::vector<double>& rmax, double s, double skin);
  /// Whether a pair not on the list may have come within reach since build(): twice the largest
  /// displacement plus twice the growth of the largest bounding radius exceeds the skin.
  bool stale(const std::vector<Eigen::Vector3d>& x, double s, double rmax_max) const;

  std::vector<PairSlot>& slots() { return pairs_; }
  const std::vector<PairSlot>& slots() const { return pairs_; }
  /// Grain i's pairs, as indices into slots() in list order.
  std::span<const int> of(std::size_t i) const {
    return {adj_.data() + adj_start_[i], adj_.data() + adj_start_[i + 1]};
  }

 private:
  std::vector<PairSlot> pairs_;
  std::vector<int> adj_start_, adj_;  // CSR: grain i's pairs are adj_[adj_start_[i] .. adj_start_[i + 1])
  std::vector<Eigen::Vector3d> x_build_;
  double s_build_ = 1.0, skin_ = 0.0;
};

}  // namespace graintwin::synth::detail
