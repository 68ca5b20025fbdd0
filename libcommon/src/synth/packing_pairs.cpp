// The packer's candidate pairs (packing_pairs.hpp).
#include "packing_pairs.hpp"

#include <algorithm>

#include "graintwin/core/point_grid.hpp"

namespace graintwin::synth::detail {

void CandidatePairs::build(const std::vector<Eigen::Vector3d>& x, const std::vector<double>& rmax, double s,
                           double skin) {
  const std::size_t n = x.size();
  skin_ = skin;
  const double rmax_max = *std::max_element(rmax.begin(), rmax.end());
  // Cells as wide as the farthest reach: a grain's partners lie in the cells next to its own.
  const PointGrid grid(x, 2.0 * s * rmax_max + skin);
  std::vector<std::vector<int>> near(n);
#pragma omp parallel for schedule(dynamic, 64) if (n > kParallelGrains)
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<int>& mine = near[i];
    grid.for_each_within(x[i], s * (rmax[i] + rmax_max) + skin, [&](std::size_t j, double) {
      if (j <= i) return;
      const double reach = s * (rmax[i] + rmax[j]) + skin;
      if ((x[j] - x[i]).squaredNorm() < reach * reach) mine.push_back(static_cast<int>(j));
    });
    std::sort(mine.begin(), mine.end());
  }
  pairs_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    for (int j : near[i]) {
      PairSlot slot;
      slot.a = static_cast<int>(i);
      slot.b = j;
      pairs_.push_back(slot);
    }
  }
  adj_start_.assign(n + 1, 0);
  for (const PairSlot& pr : pairs_) {
    ++adj_start_[pr.a + 1];
    ++adj_start_[pr.b + 1];
  }
  for (std::size_t i = 0; i < n; ++i) adj_start_[i + 1] += adj_start_[i];
  adj_.assign(adj_start_[n], 0);
  std::vector<int> fill(adj_start_.begin(), adj_start_.end() - 1);
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    adj_[fill[pairs_[k].a]++] = static_cast<int>(k);
    adj_[fill[pairs_[k].b]++] = static_cast<int>(k);
  }
  x_build_ = x;
  s_build_ = s;
}

bool CandidatePairs::stale(const std::vector<Eigen::Vector3d>& x, double s, double rmax_max) const {
  double dmax = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) dmax = std::max(dmax, (x[i] - x_build_[i]).norm());
  return 2.0 * dmax + 2.0 * (s - s_build_) * rmax_max > skin_;
}

}  // namespace graintwin::synth::detail
