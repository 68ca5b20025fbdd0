// labels2shapes: CLI contract, the shapes file, surfaces for ParaView and STL, grey-level mode, and
// bad inputs failing cleanly.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

constexpr double kVoxel = 2e-5;
// Eight spheres of radius 6-8 voxels, apart from each other.
const std::vector<test::Ball> kBalls = test::jittered_lattice(2, 7.0, 18.0, 11.0, 0.5, 0.1, 3);

std::filesystem::path write_labels(const test::TempDir& dir, const std::string& name = "labels.h5") {
  segment::LabelsFile c;
  c.labels = test::label_balls({40, 40, 40}, kBalls, {kVoxel, kVoxel, kVoxel});
  c.grains = segment::grain_table(c.labels);
  c.parameters_json = "{}";
  segment::write_labels_file(dir / name, c, {"phantom labels"});
  return dir / name;
}

std::filesystem::path write_scan(const test::TempDir& dir) {
  const Volume<float> f = test::scan_balls({40, 40, 40}, kBalls, 2, 0.02, {kVoxel, kVoxel, kVoxel});
  const Volume<std::uint16_t> v = test::uint16_scan(f);
  io::write_volume_file(dir / "scan.h5", v, {"phantom scan"});
  return dir / "scan.h5";
}

void fail(const test::TempDir& dir, const std::vector<std::string>& args, int code, const std::string& words) {
  test::expect_clean_failure("labels2shapes", dir, args, code, words);
}

}  // namespace

TEST(Labels2shapes, StandardCli) { test::expect_standard_cli("labels2shapes"); }

TEST(Labels2shapes, MeasuresSpheresAndWritesShapesAndSurfaces) {
  test::TempDir dir;
  const auto labels = write_labels(dir);
  const auto r = run_tool("labels2shapes", {labels.string(), (dir / "shapes.h5").string(), "--surfaces",
                                            (dir / "grains.vtp").string(), "--degree", "10"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("8 grains"), std::string::npos) << r.err;
  const shape::ShapesFile s = shape::read_shapes_file(dir / "shapes.h5");
  EXPECT_EQ(s.degree, 10);
  ASSERT_EQ(s.grains.size(), 8u);
  for (std::size_t i = 0; i < 8; ++i) {
    const shape::GrainShape& g = s.grains[i];
    EXPECT_EQ(g.label, i + 1);
    const double r_true = kBalls[i].r * kVoxel;
    EXPECT_NEAR(g.coeffs[0] / std::sqrt(4 * std::numbers::pi) / r_true, 1.0, 0.03) << i;
    EXPECT_NEAR(g.sphericity, 1.0, 0.05) << i;
    EXPECT_EQ(g.flags & shape::shape_flag::unreliable_fit, 0) << i;
  }
  EXPECT_GT(s.psd.d50, 2 * 6 * kVoxel);
  EXPECT_LT(s.psd.d50, 2 * 8 * kVoxel);
  EXPECT_EQ(s.psd.percent_passing.back(), 100.0);
  const auto p = nlohmann::json::parse(s.parameters_json);
  EXPECT_EQ(p["surface"], "labels");
  const io::H5File f = io::H5File::open(dir / "shapes.h5");
  EXPECT_EQ(io::read_history(f).front(), "phantom labels");
  EXPECT_EQ(f.attr_string("/sh/coeffs", "basis"), std::string(shape::kShBasisDescription));
  // ParaView: 8 icospheres of 642 points and 1280 triangles, labelled.
  const auto v = test::vtk_summary(dir / "grains.vtp");
  EXPECT_EQ(v["points"], 8 * 642);
  EXPECT_EQ(v["polys"], 8 * 1280);
  EXPECT_EQ(v["cell_data"]["label"]["range"][1], 8.0);
}

TEST(Labels2shapes, GreyLevelsStlAndTolerance) {
  test::TempDir dir;
  const auto labels = write_labels(dir);
  const auto scan = write_scan(dir);
  const auto r = run_tool("labels2shapes", {labels.string(), scan.string(), (dir / "s.h5").string(), "--surfaces",
                                            (dir / "g.stl").string(), "--surface-subdivisions", "1", "--tol", "0.03"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("grey levels: void"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("point spread"), std::string::npos) << r.err;
  const shape::ShapesFile s = shape::read_shapes_file(dir / "s.h5");
  EXPECT_EQ(nlohmann::json::parse(s.parameters_json)["surface"], "grey");
  // The phantom's blur of 0.8 voxel (test::scan_balls), read off the grains' edges.
  EXPECT_NEAR(nlohmann::json::parse(s.parameters_json)["point_spread_vox"].get<double>(), 0.8, 0.25);
  for (const auto& g : s.grains) EXPECT_LT(g.sh_degree, 15);  // spheres need few degrees at 3 % tolerance
  // Binary STL: 80-byte header, count, 50 bytes per triangle (8 grains x 80 triangles).
  EXPECT_EQ(std::filesystem::file_size(dir / "g.stl"), 84u + 50u * 8u * 80u);
}

TEST(Labels2shapes, BadInputsFailCleanly) {
  test::TempDir dir;
  const auto labels = write_labels(dir);
  const auto scan = write_scan(dir);
  const std::string out = (dir / "out.h5").string();
  fail(dir, {scan.string(), out}, 2, "pass the output of ct2labels");
  fail(dir, {labels.string(), labels.string(), out}, 2, "pass the scan that was segmented");
  fail(dir, {labels.string(), out, "--surface", "grey"}, 2, "needs the scan");
  fail(dir, {labels.string(), out, "--surface", "wobbly"}, 2, "--surface");
  fail(dir, {labels.string(), out, "--surfaces", (dir / "g.obj").string()}, 2, ".vtp or .stl");
  // A scan of another size.
  io::write_volume_file(dir / "small.h5", Volume<std::uint16_t>({10, 10, 10}, {kVoxel, kVoxel, kVoxel}), {"small"});
  fail(dir, {labels.string(), (dir / "small.h5").string(), out}, 2, "10 x 10 x 10");
  // NaN grey values.
  Volume<float> nan({40, 40, 40}, {kVoxel, kVoxel, kVoxel});
  nan(3, 3, 3) = std::numeric_limits<float>::quiet_NaN();
  io::write_volume_file(dir / "nan.h5", nan, {"nan"});
  fail(dir, {labels.string(), (dir / "nan.h5").string(), out}, 1, "NaN");
  // Grey levels out of order or outside the scan's values (0 to about 4000) would put every surface
  // where the data say nothing.
  fail(dir, {labels.string(), scan.string(), out, "--grey-void", "3000", "--grey-grain", "1000"}, 2,
       "the grain grey level 1000 must exceed the void grey level 3000 (--grey-grain, --grey-void)");
  fail(dir, {labels.string(), scan.string(), out, "--grey-grain", "1e308"}, 2, "must lie within the grey values of");
  fail(dir, {labels.string(), scan.string(), out, "--grey-void", "-1"}, 2, "--grey-void -1");
  // No grain at all.
  segment::LabelsFile empty;
  empty.labels = Volume<std::uint32_t>({8, 8, 8}, {kVoxel, kVoxel, kVoxel});
  empty.parameters_json = "{}";
  segment::write_labels_file(dir / "empty.h5", empty, {"empty"});
  fail(dir, {(dir / "empty.h5").string(), out}, 1, "holds no grain");
}

TEST(Labels2shapes, GrainTableShorterThanTheImageIsRefusedNotDropped) {
  test::TempDir dir;
  segment::LabelsFile c;
  c.labels = test::label_balls({40, 40, 40}, kBalls, {kVoxel, kVoxel, kVoxel});
  c.grains = segment::grain_table(c.labels);
  c.grains.resize(5);  // grains 6 to 8 keep their voxels but lose their rows
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "short.h5", c, {"a table three rows short"});
  fail(dir, {(dir / "short.h5").string(), (dir / "shapes.h5").string()}, 1,
       "the grain table of " + (dir / "short.h5").string() + " does not match its label image: 3 grains of the label "
       "image have no row in the grain table (labels 6 to 8); rewrite the file with ct2labels");
}

TEST(Labels2shapes, TooFewDirectionsLowerTheDegreeWithAWarning) {
  test::TempDir dir;
  const auto labels = write_labels(dir);
  const auto r = run_tool("labels2shapes", {labels.string(), (dir / "s.h5").string(), "--degree", "12", "--directions", "60"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("SH degree lowered from 12"), std::string::npos) << r.err;
  EXPECT_LT(shape::read_shapes_file(dir / "s.h5").degree, 7);
}

// A billion directions took 22.9 GB before failing with advice about crops; NaN passed --tol.
// Ranges refuse them at once; within range, the fitter's size is checked against the memory.
TEST(Labels2shapes, OptionsOutsideTheirRangeAndFittersBeyondTheMemoryAreRefused) {
  test::TempDir dir;
  const auto labels = write_labels(dir);
  const std::string out = (dir / "out.h5").string();
  fail(dir, {labels.string(), out, "--directions", "1000000000"}, 2, "--directions: must be a whole number in [0, 1000000], not 1000000000");
  fail(dir, {labels.string(), out, "--tol", "nan"}, 2, "--tol: must be a finite number in [0, 1], not nan");
  fail(dir, {labels.string(), out, "--smooth-vox", "1e6"}, 2, "[0, 10] voxels");
  fail(dir, {labels.string(), out, "--degree", "41"}, 2, "[0, 40]");
  // Under a 2 GB address-space limit a degree-40 fit over a million directions (54 GB) is refused
  // with the numbers and the largest count that fits.
  const auto before = test::list_dir(dir.path());
  const auto r = test::run_tool_with_memory_limit("labels2shapes", 2000000000,
                                                  {labels.string(), out, "--degree", "40", "--directions", "1000000"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("labels2shapes needs about 54 GB for 1000000 sample directions x 1681 SH coefficients (degree 40), "
                       "more than the 2 GB of the address-space limit (ulimit -v); give --directions of at most 37163 or a lower --degree"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(test::list_dir(dir.path()), before);
}

// The star-shape test through the tool: a hollow grain (a closed cavity holding 5 % of its volume)
// beside a solid one; the measures are stored, the log counts the reasons, and the thresholds are
// options.
TEST(Labels2shapes, HollowGrainIsFlaggedWithItsMeasuresAndTheThresholdsAreOptions) {
  test::TempDir dir;
  segment::LabelsFile c;
  c.labels = test::label_hollow_grain_and_ball(72, {kVoxel, kVoxel, kVoxel});
  c.grains = segment::grain_table(c.labels);
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "labels.h5", c, {"phantom labels"});
  const auto r = run_tool("labels2shapes", {(dir / "labels.h5").string(), (dir / "s.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("star shape: 1 grains with re-entrant rays above the noise floor; 1 enclose more than 1 % of their "
                       "volume as void, 1 miss a surface deeper than 20 um"),
            std::string::npos)
      << r.err;
  const shape::ShapesFile s = shape::read_shapes_file(dir / "s.h5");
  ASSERT_EQ(s.grains.size(), 2u);
  const double expected = std::pow(5.5, 3) / (std::pow(15.0, 3) - std::pow(5.5, 3));
  EXPECT_NEAR(s.grains[0].hidden_void_fraction / expected, 1.0, 0.1);
  EXPECT_GT(s.grains[0].reentry_depth, 10 * kVoxel);
  EXPECT_TRUE(s.grains[0].flags & shape::shape_flag::unreliable_fit);
  EXPECT_EQ(s.grains[1].hidden_void_fraction, 0.0);
  EXPECT_EQ(s.grains[1].reentry_depth, 0.0);
  EXPECT_EQ(s.grains[1].flags & (shape::shape_flag::not_star_shaped | shape::shape_flag::unreliable_fit), 0);
  // The smoothed labels' edge width: sigma 0.7 and the voxel box, read through the interpolation.
  EXPECT_NEAR(s.grains[1].edge_sigma / kVoxel, 0.8, 0.15);
  const io::H5File f = io::H5File::open(dir / "s.h5");
  EXPECT_EQ(f.attr_string(schema::shapes::reentry_depth, "units"), "m");
  // Looser thresholds keep the fit: the cavity is still reported, not flagged unreliable.
  const auto loose = run_tool("labels2shapes", {(dir / "labels.h5").string(), (dir / "loose.h5").string(), "--max-hidden-void",
                                                "0.1", "--max-reentry-depth", "20"});
  ASSERT_EQ(loose.exit_code, 0) << loose.err;
  const shape::ShapesFile l = shape::read_shapes_file(dir / "loose.h5");
  EXPECT_TRUE(l.grains[0].flags & shape::shape_flag::not_star_shaped);
  EXPECT_FALSE(l.grains[0].flags & shape::shape_flag::unreliable_fit);
  EXPECT_EQ(nlohmann::json::parse(l.parameters_json)["max_hidden_void"], 0.1);
  fail(dir, {(dir / "labels.h5").string(), (dir / "x.h5").string(), "--max-hidden-void", "2"}, 2, "[0, 1]");
  fail(dir, {(dir / "labels.h5").string(), (dir / "x.h5").string(), "--point-spread", "-1"}, 2, "[0, 10] voxels");
}
