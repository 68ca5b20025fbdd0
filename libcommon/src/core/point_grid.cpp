#include "graintwin/core/point_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"

namespace graintwin {

PointGrid::PointGrid(const std::vector<Eigen::Vector3d>& points, double cell) : points_(points), cell_(cell) {
  if (!(cell > 0.0) || !std::isfinite(cell)) throw UsageError("PointGrid: the cell size must be positive and finite");
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& p : points_)
    if (p.allFinite()) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (!(lo.x() <= hi.x())) {  // no finite point: an empty grid
    dims_[0] = dims_[1] = dims_[2] = 1;
    start_.assign(2, 0);
    return;
  }
  origin_ = lo;
  // Widen the cell until the grid has at most ~4 cells per point (and at least one).
  const double max_cells = 4.0 * static_cast<double>(points_.size()) + 64.0;
  for (;;) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k) cells *= std::floor((hi[k] - lo[k]) / cell_) + 1.0;
    if (cells <= max_cells) break;
    cell_ *= 1.25;
  }
  for (int k = 0; k < 3; ++k) dims_[k] = static_cast<int>(std::floor((hi[k] - lo[k]) / cell_)) + 1;
  const std::size_t ncell = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  std::vector<std::uint32_t> cell_of(points_.size(), std::numeric_limits<std::uint32_t>::max());
  start_.assign(ncell + 1, 0);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (!points_[i].allFinite()) continue;
    std::size_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = std::min(static_cast<std::size_t>((points_[i][k] - origin_[k]) / cell_), static_cast<std::size_t>(dims_[k] - 1));
    cell_of[i] = static_cast<std::uint32_t>((c[2] * dims_[1] + c[1]) * dims_[0] + c[0]);
    ++start_[cell_of[i] + 1];
  }
  for (std::size_t k = 0; k < ncell; ++k) start_[k + 1] += start_[k];
  order_.resize(start_[ncell]);
  std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < points_.size(); ++i)
    if (cell_of[i] != std::numeric_limits<std::uint32_t>::max()) order_[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
}

std::vector<std::size_t> PointGrid::within(const Eigen::Vector3d& q, double r) const {
  std::vector<std::size_t> out;
  for_each_within(q, r, [&](std::size_t i, double) { out.push_back(i); });
  std::sort(out.begin(), out.end());
  return out;
}

std::size_t PointGrid::nearest(const Eigen::Vector3d& q, double r_max, std::size_t exclude) const {
  std::size_t best = size();
  double best_d2 = std::numeric_limits<double>::infinity();
  for_each_within(q, r_max, [&](std::size_t i, double d2) {
    if (i != exclude && (d2 < best_d2 || (d2 == best_d2 && i < best))) best = i, best_d2 = d2;
  });
  return best;
}

}  // namespace graintwin
