// The report's sections (report/sections): plane cuts of closed surfaces against exact areas, the
// twin's grains posed at a frame (turned and moved rigidly), the colour scale's percentiles, slice
// indices, and the planes of a labels file (through its cylinder's axis, else the image's middle).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "graintwin/fdem/primitives.hpp"
#include "graintwin/report/sections.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::report;

namespace {

/// The unit octahedron |x| + |y| + |z| <= 1, outward triangles.
struct Octahedron {
  std::vector<Eigen::Vector3d> vertices{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<std::uint32_t, 3>> triangles{{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                       {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
};

double area(const std::vector<Eigen::Vector2d>& loop) {
  double twice = 0.0;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const Eigen::Vector2d& a = loop[i];
    const Eigen::Vector2d& b = loop[(i + 1) % loop.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return std::abs(0.5 * twice);
}

}  // namespace

TEST(ReportSections, APlaneCutsAClosedSurfaceInClosedOutlinesOfTheExactArea) {
  const Octahedron o;
  // z = 0.5: the square |x| + |y| <= 0.5, area 2 x 0.5^2.
  auto loops = cut_surface(o.vertices, o.triangles, SectionPlane::xy, 0.5);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 4u);
  EXPECT_NEAR(area(loops[0]), 0.5, 1e-12);
  // y = 0 runs through four vertices: they count as above, and the outline is still the whole
  // square |x| + |z| <= 1 in (x, z).
  loops = cut_surface(o.vertices, o.triangles, SectionPlane::xz, 0.0);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_NEAR(area(loops[0]), 2.0, 1e-12);
  for (const Eigen::Vector2d& p : loops[0]) EXPECT_NEAR(std::abs(p.x()) + std::abs(p.y()), 1.0, 1e-12);
  // A plane beside the surface cuts nothing; an open surface gives an open polyline.
  EXPECT_TRUE(cut_surface(o.vertices, o.triangles, SectionPlane::xy, 1.5).empty());
  const std::vector<std::array<std::uint32_t, 3>> one{{0, 2, 4}};
  loops = cut_surface(o.vertices, one, SectionPlane::xy, 0.5);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 2u);
}

TEST(ReportSections, TheTwinsGrainsAreCutWhereTheFramePutsThem) {
  // Two 1 mm cubes; at the frame the first is turned 45 degrees about z and moved, the second far
  // from the plane.
  fdem::Model model;
  const fdem::TetMesh cube = fdem::box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  fdem::add_grain(model, cube, Eigen::Vector3d(0.5e-3, 0.5e-3, 0.5e-3), fdem::GrainKind::rigid, 0, 7);
  fdem::add_grain(model, cube, Eigen::Vector3d(5e-3, 0.5e-3, 0.5e-3), fdem::GrainKind::rigid, 0, 9);
  TwinSurfaces surfaces(model);
  EXPECT_NEAR(surfaces.reach(0), std::sqrt(3.0) * 1e-3, 1e-15) << "the diagonal of the cube";
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(std::numbers::pi / 4, Eigen::Vector3d::UnitZ()));
  const std::vector<Eigen::Vector3d> centroid{{2e-3, 3e-3, 4e-3}, {5e-3, 9e-3, 0.5e-3}};
  const std::vector<Eigen::Vector4d> rotation{{turn.w(), turn.x(), turn.y(), turn.z()}, {1, 0, 0, 0}};
  // y = 3 mm through the turned cube's centre: a sqrt(2) mm wide, 1 mm tall rectangle about (2, 4) mm.
  const auto outlines = twin_section(surfaces, centroid, rotation, SectionPlane::xz, 3e-3);
  ASSERT_EQ(outlines.size(), 1u);
  EXPECT_EQ(outlines[0].label, 7u);
  ASSERT_EQ(outlines[0].loops.size(), 1u);
  EXPECT_NEAR(area(outlines[0].loops[0]), std::sqrt(2.0) * 1e-6, 1e-15);
  double x_lo = 1, x_hi = -1, z_lo = 1, z_hi = -1;
  for (const Eigen::Vector2d& p : outlines[0].loops[0])
    x_lo = std::min(x_lo, p.x()), x_hi = std::max(x_hi, p.x()), z_lo = std::min(z_lo, p.y()), z_hi = std::max(z_hi, p.y());
  EXPECT_NEAR(x_lo, 2e-3 - std::sqrt(0.5) * 1e-3, 1e-12);
  EXPECT_NEAR(x_hi, 2e-3 + std::sqrt(0.5) * 1e-3, 1e-12);
  EXPECT_NEAR(z_lo, 3.5e-3, 1e-12);
  EXPECT_NEAR(z_hi, 4.5e-3, 1e-12);
  // The horizontal plane z = 0.5 mm cuts only the second cube: a 1 mm square about (5, 9) mm.
  const auto low = twin_section(surfaces, centroid, rotation, SectionPlane::xy, 0.5e-3);
  ASSERT_EQ(low.size(), 1u);
  EXPECT_EQ(low[0].label, 9u);
  EXPECT_NEAR(area(low[0].loops[0]), 1e-6, 1e-15);
  EXPECT_NEAR((surfaces.reference_centroid(0) - Eigen::Vector3d::Constant(0.5e-3)).norm(), 0.0, 1e-15);
}

TEST(ReportSections, TheColourScaleSpansThePercentilesOfTheDefinedValues) {
  std::vector<double> v;
  for (int i = 1; i <= 101; ++i) v.push_back(i);
  v.push_back(std::nan(""));
  EXPECT_EQ(colour_range(v, false), (std::array<double, 2>{2.0, 100.0}));
  v.push_back(-5.0);
  EXPECT_EQ(colour_range(v, true), (std::array<double, 2>{2.0, 100.0})) << "a log scale leaves out values that are not positive";
  EXPECT_EQ(colour_range({3.0}, false), (std::array<double, 2>{1.5, 4.5}));
  const auto one = colour_range({0.1, 0.1}, true);
  EXPECT_NEAR(one[0] * one[1], 0.01, 1e-15);
  EXPECT_TRUE(std::isnan(colour_range({-1.0, 0.0}, true)[0]));
}

TEST(ReportSections, SliceIndicesAreTheVoxelsHoldingThePlaneClampedIntoTheImage) {
  EXPECT_EQ(slice_index(2.4, 0.0, 1.0, 10), 2u);
  EXPECT_EQ(slice_index(2.6, 0.0, 1.0, 10), 3u);
  EXPECT_EQ(slice_index(-3.0, 0.0, 1.0, 10), 0u);
  EXPECT_EQ(slice_index(30.0, 0.0, 1.0, 10), 9u);
  EXPECT_EQ(slice_index(std::nan(""), 0.0, 1.0, 10), 0u);
}

TEST(ReportSections, TheScansPlanesRunThroughItsCylinderElseTheImagesMiddle) {
  test::TempDir dir;
  segment::LabelsFile c;
  c.labels = Volume<std::uint32_t>({21, 10, 8}, {2e-4, 1e-4, 1e-4}, {1e-3, -5e-4, 0.0});
  c.labels(5, 5, 4) = 1;
  c.grains = segment::grain_table(c.labels);
  c.sample.region.radius = std::nan("");
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "whole.h5", c, {"test"});
  ScanPlanes p = scan_planes(dir / "whole.h5");
  // x: 8 voxels of 0.1 mm from 0; y: 10 from -0.5 mm; z: 21 of 0.2 mm from 1 mm (voxel centres).
  EXPECT_NEAR(p.extent[0], -0.5e-4, 1e-15);
  EXPECT_NEAR(p.extent[1], 7.5e-4, 1e-15);
  EXPECT_NEAR(p.extent[4], 0.9e-3, 1e-15);
  EXPECT_NEAR(p.extent[5], 5.1e-3, 1e-15);
  EXPECT_NEAR(p.axis_y, 0.5 * (p.extent[2] + p.extent[3]), 1e-15);
  EXPECT_NEAR(p.mid_z, 3.0e-3, 1e-15);
  EXPECT_EQ(p.z_index, 10u);
  c.sample.region.radius = 3e-4, c.sample.region.centre_x = 1e-4, c.sample.region.centre_y = -2e-4;
  c.sample.region.z_min = 1.2e-3, c.sample.region.z_max = 2.0e-3;
  segment::write_labels_file(dir / "cylinder.h5", c, {"test"});
  p = scan_planes(dir / "cylinder.h5");
  EXPECT_NEAR(p.axis_y, -2e-4, 1e-15);
  EXPECT_EQ(p.y_index, 3u);
  EXPECT_NEAR(p.mid_z, 1.6e-3, 1e-15);
  EXPECT_EQ(p.z_index, 3u);
}
