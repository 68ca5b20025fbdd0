// The report's 3D pictures: the force-chain network (report/force_network: a frame's contacts
// that push their grains apart become segments between the grains' centroids, with their normal
// forces; the strong network keeps those at or above the mean force) and the camera box of the
// D2min clusters (report/clusters_3d).
#include <gtest/gtest.h>

#include <limits>

#include "graintwin/report/clusters_3d.hpp"
#include "graintwin/report/force_network.hpp"

using namespace graintwin;
using namespace graintwin::report;

TEST(ReportForceNetwork, CompressiveContactsRunFromCentroidToCentroid) {
  const std::vector<Eigen::Vector3d> centroid{{0, 0, 0}, {1, 0, 0}, {0, 0, 2}};
  micro::FrameContacts contacts;
  contacts.pair = {{0, 1}, {0, 2}, {1, 2}};
  contacts.normal = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX()};
  contacts.normal_force = {3.0, 0.0, -1.0};  // pushing, touching without force, pulling
  const ForceNetwork n = force_network(centroid, contacts);
  ASSERT_EQ(n.force.size(), 1u) << "only contacts pushing their grains apart carry a chain";
  EXPECT_EQ(n.force[0], 3.0);
  EXPECT_EQ(n.from[0], centroid[0]);
  EXPECT_EQ(n.to[0], centroid[1]);
}

TEST(ReportForceNetwork, TheStrongNetworkKeepsTheContactsAtOrAboveTheMeanForce) {
  ForceNetwork n;
  for (double f : {1.0, 2.0, 3.0, 6.0}) n.from.emplace_back(f, 0, 0), n.to.emplace_back(f, 1, 0), n.force.push_back(f);
  const ForceNetwork strong = strong_network(n);  // mean 3
  ASSERT_EQ(strong.force, (std::vector<double>{3.0, 6.0}));
  EXPECT_EQ(strong.from[1], Eigen::Vector3d(6, 0, 0));
  EXPECT_TRUE(strong_network(ForceNetwork{}).force.empty());
}

TEST(ReportClusters3d, TheCameraBoxHoldsEverySphereWhole) {
  const double inf = std::numeric_limits<double>::infinity();
  const auto b = sphere_bounds({0, 0, 0, 4, 1, -2}, {1.0, 0.5}, {inf, -inf, inf, -inf, inf, -inf});
  EXPECT_EQ(b, (std::array<double, 6>{-1.0, 4.5, -1.0, 1.5, -2.5, 1.0}));
  EXPECT_EQ(sphere_bounds({}, {}, b), b);
}
