// Marching tetrahedra: area and volume of analytic level sets, orientation, crack-free closure.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "graintwin/shape/isosurface.hpp"

using namespace graintwin;
using namespace graintwin::shape;

TEST(Isosurface, SphereAreaAndVolume) {
  // Signed distance to a sphere of radius 9.3 voxels (anisotropic voxels to test the geometry).
  const Vec3 vs{2e-5, 1e-5, 1.5e-5};  // z, y, x
  const double R = 9.3 * 2e-5;
  Volume<float> f({24, 44, 32}, vs, {-0.1e-3, 0.0, 0.0});
  const Eigen::Vector3d c(16 * 1.5e-5, 22e-5, 12 * 2e-5 - 0.1e-3);
  for (std::size_t z = 0; z < 24; ++z)
    for (std::size_t y = 0; y < 44; ++y)
      for (std::size_t x = 0; x < 32; ++x) {
        const Vec3 p = f.position_xyz(double(z), double(y), double(x));
        f(z, y, x) = static_cast<float>(R - (Eigen::Vector3d(p[0], p[1], p[2]) - c).norm());
      }
  std::size_t emitted = 0;
  double outward = 0.0;
  const IsoMeasures m = isosurface(f, 0.0f, [&](const Triangle& t) {
    ++emitted;
    const Eigen::Vector3d n = (t[1] - t[0]).cross(t[2] - t[0]);
    outward += n.dot((t[0] + t[1] + t[2]) / 3.0 - c) > 0 ? 1 : -1;
  });
  EXPECT_EQ(emitted, m.triangles);
  EXPECT_EQ(outward, static_cast<double>(m.triangles));  // every normal points out
  EXPECT_NEAR(m.area / (4 * std::numbers::pi * R * R), 1.0, 0.01);
  EXPECT_NEAR(m.volume / (4.0 / 3.0 * std::numbers::pi * R * R * R), 1.0, 0.01);
}

TEST(Isosurface, BinaryCubeIsClosedAndUniformFieldsHaveNone) {
  Volume<float> f({6, 6, 6}, {1, 1, 1});
  for (std::size_t z = 2; z < 4; ++z)
    for (std::size_t y = 2; y < 4; ++y)
      for (std::size_t x = 2; x < 4; ++x) f(z, y, x) = 1.0f;
  const IsoMeasures m = isosurface(f, 0.5f);
  // The 0.5 level of a 2^3 block of ones lies half-way to the zeros: a closed, convex body whose
  // volume is the block's (2^3) minus what the interpolation cuts off at edges and corners.
  EXPECT_GT(m.volume, 4.0);
  EXPECT_LT(m.volume, 8.0);
  EXPECT_GT(m.area, 0.0);
  Volume<float> flat({4, 4, 4}, {1, 1, 1});
  EXPECT_EQ(isosurface(flat, 0.5f).triangles, 0u);
}
