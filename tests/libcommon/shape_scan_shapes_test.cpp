// labels2shapes' stage (shape/scan_shapes): the surface choice, the grey levels taken from the scan
// or refused, the content of the shapes file (size distribution, parameters), and the surfaces.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/shape/scan_shapes.hpp"
#include "support/run_tool.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::shape;

namespace {

constexpr double kVoxel = 2e-5;
// Two spheres of radius 7 and 6 voxels, apart from each other.
const std::vector<test::Ball> kBalls = {{12.0, 12.5, 11.5, 7.0}, {25.5, 26.0, 27.0, 6.0}};

/// The phantom as the stage reads it; `grey` may be null.
struct Phantom {
  Volume<std::uint32_t> labels = test::label_balls({38, 38, 38}, kBalls, {kVoxel, kVoxel, kVoxel});
  SegmentedScan scan(const AnyVolume* grey) const {
    SegmentedScan s{&labels, {}, grey, "labels.h5", "scan.h5"};
    for (const auto& g : segment::grain_table(labels)) s.grains.push_back({g.label, g.bbox});
    return s;
  }
};

/// The phantom's scan at grey levels 1000 (void) to 3000 (grain).
AnyVolume grey_scan() {
  const Volume<float> f = test::scan_balls({38, 38, 38}, kBalls, 4, 0.01, {kVoxel, kVoxel, kVoxel});
  const Volume<std::uint16_t> v = test::uint16_scan(f);
  return v;
}

ShapesParams fast_params() {
  ShapesParams p;
  p.degree = 8;
  return p;
}

}  // namespace

TEST(ScanShapes, SurfaceChoiceNamesAndTheScanDecideTheSource) {
  EXPECT_EQ(parse_surface_choice("auto"), SurfaceChoice::automatic);
  EXPECT_EQ(parse_surface_choice("grey"), SurfaceChoice::grey);
  EXPECT_EQ(parse_surface_choice("labels"), SurfaceChoice::labels);
  try {
    parse_surface_choice("wobbly");
    FAIL() << "an unknown surface was accepted";
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--surface 'wobbly' is not auto, grey or labels");
  }
  EXPECT_STREQ(surface_source_name(SurfaceSource::grey), "grey");
  EXPECT_STREQ(surface_source_name(SurfaceSource::labels), "labels");
  EXPECT_EQ(surface_source(SurfaceChoice::automatic, true), SurfaceSource::grey);
  EXPECT_EQ(surface_source(SurfaceChoice::automatic, false), SurfaceSource::labels);
  EXPECT_EQ(surface_source(SurfaceChoice::labels, true), SurfaceSource::labels);
  EXPECT_EQ(surface_source(SurfaceChoice::grey, true), SurfaceSource::grey);
  EXPECT_THROW(surface_source(SurfaceChoice::grey, false), UsageError);
}

TEST(ScanShapes, LabelsSurfaceGivesTheShapesFileContent) {
  const Phantom ph;
  const ShapesParams p = fast_params();
  const ShFitter fitter = shapes_fitter(p);
  const ShapesFile c = scan_shapes(ph.scan(nullptr), fitter, p);
  ASSERT_EQ(c.grains.size(), 2u);
  EXPECT_EQ(c.degree, 8);
  // Voxel-count volumes of spheres of radius 7 and 6 voxels, within the voxelisation.
  const double v0 = 4.0 / 3.0 * std::numbers::pi * std::pow(7.0 * kVoxel, 3), v1 = 4.0 / 3.0 * std::numbers::pi * std::pow(6.0 * kVoxel, 3);
  EXPECT_NEAR(c.grains[0].volume, v0, 0.05 * v0);
  EXPECT_NEAR(c.grains[1].volume, v1, 0.05 * v1);
  // The size distribution by volume: the smaller grain holds v1 / (v0 + v1) of it.
  ASSERT_EQ(c.psd.percent_passing.size(), 2u);
  EXPECT_NEAR(c.psd.percent_passing[0], 100.0 * c.grains[1].volume / (c.grains[0].volume + c.grains[1].volume), 1e-9);
  const nlohmann::json j = nlohmann::json::parse(c.parameters_json);
  EXPECT_EQ(j["surface"], "labels");
  EXPECT_EQ(j["smooth_vox"], 0.7);  // the labels surface's default
  EXPECT_EQ(j["requested_degree"], 8);
  EXPECT_FALSE(j.contains("grey_levels"));
}

TEST(ScanShapes, GreySurfaceTakesTheScansLevelsUnlessGiven) {
  const Phantom ph;
  const AnyVolume grey = grey_scan();
  ShapesParams p = fast_params();
  p.point_spread_vox = 0.8;
  const ShFitter fitter = shapes_fitter(p);
  const nlohmann::json measured = nlohmann::json::parse(scan_shapes(ph.scan(&grey), fitter, p).parameters_json);
  EXPECT_EQ(measured["surface"], "grey");
  EXPECT_EQ(measured["smooth_vox"], 0.0);  // the grey surface's default
  EXPECT_EQ(measured["point_spread_vox"], 0.8);
  // scan_balls: grey 0.25 + 0.5 occupancy, here x 4000.
  EXPECT_NEAR(measured["grey_levels"][0].get<double>(), 1000.0, 60.0);
  EXPECT_NEAR(measured["grey_levels"][1].get<double>(), 3000.0, 60.0);
  p.grey_void = 1100.0, p.grey_grain = 2900.0;
  const nlohmann::json given = nlohmann::json::parse(scan_shapes(ph.scan(&grey), fitter, p).parameters_json);
  EXPECT_EQ(given["grey_levels"][0], 1100.0);
  EXPECT_EQ(given["grey_levels"][1], 2900.0);
}

TEST(ScanShapes, RefusesWhatCannotBeMeasured) {
  const Phantom ph;
  const AnyVolume grey = grey_scan();
  ShapesParams p = fast_params();
  const ShFitter fitter = shapes_fitter(p);
  // Grey levels out of order, or outside the scan's own range.
  p.grey_void = 3000.0, p.grey_grain = 1000.0;
  EXPECT_THROW(scan_shapes(ph.scan(&grey), fitter, p), UsageError);
  p.grey_void = -5.0, p.grey_grain = 3000.0;
  EXPECT_THROW(scan_shapes(ph.scan(&grey), fitter, p), UsageError);
  // A uint32 scan is a label image.
  const AnyVolume labels_as_grey = ph.labels;
  try {
    scan_shapes(ph.scan(&labels_as_grey), fitter, fast_params());
    FAIL() << "a uint32 scan was measured";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("scan.h5 is uint32"), std::string::npos) << e.message();
    ASSERT_FALSE(e.context().empty());
    EXPECT_EQ(e.context()[0], "while measuring the grains of labels.h5");
  }
  // No grains.
  SegmentedScan empty = ph.scan(nullptr);
  empty.grains.clear();
  EXPECT_THROW(scan_shapes(empty, fitter, fast_params()), DataError);
  // A fitter too large for any memory.
  ShapesParams huge = fast_params();
  huge.degree = 40, huge.directions = 1000000000;
  EXPECT_THROW(shapes_fitter(huge), UsageError);
}

TEST(ScanShapes, SurfacesAreOneIcospherePerGrain) {
  const Phantom ph;
  const ShapesParams p = fast_params();
  const ShapesFile c = scan_shapes(ph.scan(nullptr), shapes_fitter(p), p);
  test::TempDir dir;
  write_shape_surfaces(dir / "g.stl", true, c.grains, c.degree, 1);
  // Binary STL: 80-byte header, count, 50 bytes per triangle (2 grains x 80 triangles).
  EXPECT_EQ(std::filesystem::file_size(dir / "g.stl"), 84u + 50u * 2u * 80u);
  write_shape_surfaces(dir / "g.vtp", false, c.grains, c.degree, 1);
  EXPECT_GT(std::filesystem::file_size(dir / "g.vtp"), 0u);
}
