#pragma once
// A uniform cell grid over a fixed set of points, for "every point within r of q" queries in time
// proportional to the points near q (the matchers' candidate windows, the micro-mechanics'
// neighbourhoods, clusters and g(r); never an all-pairs loop). Points are stored cell by cell
// (CSR layout), so a query reads contiguous memory.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace graintwin {

class PointGrid {
 public:
  PointGrid() = default;
  /// Indexes `points` (copied) with cells about `cell` wide (> 0; UsageError otherwise). The cell
  /// is widened when needed so the grid has at most about 4 cells per point, so a few far outliers
  /// cannot make it huge. Non-finite points are left out of every query.
  PointGrid(const std::vector<Eigen::Vector3d>& points, double cell);

  std::size_t size() const { return points_.size(); }
  double cell() const { return cell_; }
  const Eigen::Vector3d& point(std::size_t i) const { return points_[i]; }

  /// Calls f(index, squared distance) for every point with |p - q| <= r, in increasing cell order
  /// then index order (deterministic). r < 0 finds nothing.
  template <class F>
  void for_each_within(const Eigen::Vector3d& q, double r, F&& f) const {
    if (r < 0.0 || points_.empty() || !q.allFinite()) return;
    const double r2 = r * r;
    int lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      const double a = (q[k] - r - origin_[k]) / cell_, b = (q[k] + r - origin_[k]) / cell_;
      if (b < 0.0 || a >= dims_[k]) return;
      lo[k] = a < 0.0 ? 0 : static_cast<int>(a);
      hi[k] = b >= dims_[k] ? dims_[k] - 1 : static_cast<int>(b);
    }
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y) {
        const std::size_t row = (static_cast<std::size_t>(z) * dims_[1] + y) * dims_[0];
        for (std::uint32_t s = start_[row + lo[0]], e = start_[row + hi[0] + 1]; s < e; ++s) {
          const std::uint32_t i = order_[s];
          const double d2 = (points_[i] - q).squaredNorm();
          if (d2 <= r2) f(static_cast<std::size_t>(i), d2);
        }
      }
  }

  /// Indices of the points within r of q, sorted by index.
  std::vector<std::size_t> within(const Eigen::Vector3d& q, double r) const;
  /// The nearest point to q other than `exclude` (pass size() to exclude none) within r_max, or
  /// size() when there is none.
  std::size_t nearest(const Eigen::Vector3d& q, double r_max, std::size_t exclude) const;

 private:
  std::vector<Eigen::Vector3d> points_;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double cell_ = 1.0;
  int dims_[3] = {0, 0, 0};
  std::vector<std::uint32_t> start_;  ///< per cell (x fastest), offset into order_; one more entry at the end
  std::vector<std::uint32_t> order_;  ///< point indices, cell by cell
};

}  // namespace graintwin
