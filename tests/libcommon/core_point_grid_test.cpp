// core/point_grid: the uniform-grid point index the matchers and the micro-mechanics search with.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"

using namespace graintwin;

TEST(PointGrid, FindsExactlyThePointsWithinTheRadius) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> inside(0.0, 10.0), around(-1.0, 11.0);
  const auto draw = [&](std::uniform_real_distribution<double>& u) {
    const double x = u(rng), y = u(rng), z = u(rng);  // one draw per statement: a fixed order
    return Eigen::Vector3d(x, y, z);
  };
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 2000; ++i) pts.push_back(draw(inside));
  pts.push_back({1e6, 0, 0});  // a far outlier must not blow the grid up
  pts.push_back({std::nan(""), 0, 0});
  const PointGrid grid(pts, 0.7);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d x = draw(around);
    const double r = 0.1 + 3.0 * q / 200.0;
    std::vector<std::size_t> brute;
    for (std::size_t i = 0; i < pts.size(); ++i)
      if ((pts[i] - x).norm() <= r) brute.push_back(i);
    ASSERT_EQ(grid.within(x, r), brute) << q;
    std::size_t nearest = pts.size();
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (pts[i].allFinite() && (pts[i] - x).norm() <= r && (nearest == pts.size() || (pts[i] - x).norm() < (pts[nearest] - x).norm()))
        nearest = i;
    EXPECT_EQ(grid.nearest(x, r, pts.size()), nearest == pts.size() ? grid.size() : nearest);
  }
  EXPECT_EQ(grid.within({1e6, 0, 0}, 1.0), std::vector<std::size_t>{2000});
  EXPECT_THROW(PointGrid(pts, 0.0), UsageError);
}
