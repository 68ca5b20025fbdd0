// truthswap: CLI contract; eight balls whose segmentation merges two of them: the labels swap gives
// the truth's image with ct2labels' cylinder and the true void ratio in it; the shapes swap gives
// the six faithful grains their exact sphere (volume, coefficients, no flag) at the measured or the
// true centroid and leaves the merged grain as measured; bad requests refused in one sentence
// with nothing written and an existing output untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using test::run_tool;
namespace fs = std::filesystem;

namespace {

constexpr double kVoxel = 1e-5;
constexpr int kGrains = 8;
/// The pair the segmentation merges (labels): 1 and 2 touch along x.
constexpr std::uint32_t kMergedA = 1, kMergedB = 2;

/// A 2 x 2 x 2 lattice of balls of radius 5.3 voxels, 10.4 apart (1 and 2 overlap a little), off the
/// voxel grid so that a voxel centroid differs from the true centre.
std::vector<test::Ball> balls() {
  std::vector<test::Ball> b;
  for (int k = 0; k < kGrains; ++k) b.push_back({8.3 + 10.6 * (k / 4), 8.6 + 12.0 * (k / 2 % 2), 8.2 + 10.4 * (k % 2), 5.3});
  return b;
}

synth::GroundTruth true_series() {
  synth::GroundTruth g;
  g.sample_height = g.sample_radius = 30 * kVoxel;
  g.labels = test::label_balls({30, 30, 30}, balls(), Vec3{kVoxel, kVoxel, kVoxel});
  g.sh_degree = 2;
  g.sh_coeffs = g.sh_coeffs_body = Eigen::MatrixXd::Zero(kGrains, 9);
  g.sh_invariants = Eigen::MatrixXd::Zero(kGrains, 3);
  for (const test::Ball& b : balls()) {
    const double r = b.r * kVoxel;
    const auto i = static_cast<Eigen::Index>(g.poses.size());
    g.poses.push_back({kVoxel * Eigen::Vector3d(b.x, b.y, b.z), Eigen::Quaterniond::Identity()});
    g.volume.push_back(4.0 / 3.0 * std::numbers::pi * r * r * r);
    g.equivalent_diameter.push_back(2 * r), g.sphericity.push_back(1.0), g.aspect_ratio.push_back(1.0);
    g.sh_coeffs(i, 0) = g.sh_coeffs_body(i, 0) = g.sh_invariants(i, 0) = r * std::sqrt(4 * std::numbers::pi);
  }
  return g;
}

/// ct2labels' file as the test's segmentation: the truth with kMergedB joined to kMergedA, in a
/// cylinder of radius 12 voxels.
segment::LabelsFile segmented(const synth::GroundTruth& t) {
  segment::LabelsFile c;
  c.labels = t.labels;
  for (std::uint32_t& v : c.labels.values()) v = v == kMergedB ? kMergedA : (v > kMergedB ? v - 1 : v);
  c.grains = segment::grain_table(c.labels);
  c.sample.region.centre_x = c.sample.region.centre_y = 15 * kVoxel;
  c.sample.region.radius = 12 * kVoxel;
  c.sample.void_ratio = {1.0, 1.0, 1.0};
  c.parameters_json = R"({"threshold": 0.5})";
  return c;
}

struct Files {
  test::TempDir dir;
  fs::path truth = dir / "truth_000.h5", labels = dir / "labels.h5", shapes = dir / "shapes.h5";
  Files() {
    const synth::GroundTruth t = true_series();
    synth::write_ground_truth(truth, t, {"truth"});
    segment::write_labels_file(labels, segmented(t), {"segmented"});
    const auto r = run_tool("labels2shapes", {labels.string(), shapes.string(), "--degree", "4"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
};

void swap_ok(const std::vector<std::string>& args) {
  const auto r = run_tool("truthswap", args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace

TEST(TruthswapCli, StandardOptions) { test::expect_standard_cli("truthswap"); }

TEST(Truthswap, ALabelsFileTakesTheTruthsImageAndKeepsTheSegmentedCylinder) {
  Files f;
  const fs::path out = f.dir / "exact_labels.h5";
  swap_ok({f.truth.string(), f.labels.string(), out.string()});
  const segment::LabelsFile swapped = segment::read_labels_file(out);
  const synth::GroundTruth t = true_series();
  EXPECT_EQ(swapped.labels.values(), t.labels.values());
  EXPECT_EQ(swapped.grains.size(), std::size_t(kGrains));
  EXPECT_EQ(swapped.sample.region.radius, 12 * kVoxel);
  // The true void ratio in that cylinder, counted as ct2labels counts its own mask.
  std::size_t solid = 0, inside = 0;
  for (std::size_t z = 0; z < 30; ++z)
    for (std::size_t y = 0; y < 30; ++y)
      for (std::size_t x = 0; x < 30; ++x)
        if (swapped.sample.region.contains(t.labels, z, y, x)) ++inside, solid += t.labels(z, y, x) != 0;
  EXPECT_DOUBLE_EQ(swapped.sample.void_ratio.e, double(inside - solid) / double(solid));
  EXPECT_NE(swapped.parameters_json.find("truth_swap"), std::string::npos);
  EXPECT_NE(swapped.parameters_json.find("threshold"), std::string::npos);
}

TEST(Truthswap, FaithfulGrainsTakeTheirExactSurfaceAtTheMeasuredOrTheTrueCentroid) {
  Files f;
  const shape::ShapesFile measured = shape::read_shapes_file(f.shapes);
  const synth::GroundTruth t = true_series();
  for (const bool positions : {false, true}) {
    const fs::path out = f.dir / (positions ? "exact_positions.h5" : "exact_shapes.h5");
    std::vector<std::string> args{f.truth.string(), f.shapes.string(), out.string(), "--labels", f.labels.string()};
    if (positions) args.push_back("--positions");
    swap_ok(args);
    const shape::ShapesFile swapped = shape::read_shapes_file(out);
    ASSERT_EQ(swapped.grains.size(), measured.grains.size());
    EXPECT_EQ(swapped.degree, 4);  // the larger of the measured 4 and the truth's 2
    for (std::size_t k = 0; k < swapped.grains.size(); ++k) {
      const shape::GrainShape &s = swapped.grains[k], &m = measured.grains[k];
      EXPECT_EQ(s.label, m.label);
      if (m.label == kMergedA) {  // not faithful: as measured
        EXPECT_EQ(s.volume, m.volume);
        EXPECT_EQ(s.coeffs.head(m.coeffs.size()), m.coeffs);
        continue;
      }
      const std::size_t grain = m.label;  // true label m.label + 1: the labels above the merge moved down one
      const double r = balls()[grain].r * kVoxel;
      EXPECT_NEAR(s.volume, 4.0 / 3.0 * std::numbers::pi * r * r * r, 1e-3 * s.volume);
      EXPECT_NEAR(s.sphericity, 1.0, 1e-3);
      EXPECT_EQ(s.coeffs[0], t.sh_coeffs(static_cast<Eigen::Index>(grain), 0));
      EXPECT_EQ(s.coeffs.size(), 25);
      EXPECT_EQ(s.flags, 0);
      EXPECT_EQ(s.rms_error, 0.0);
      if (positions)
        EXPECT_EQ(s.centroid, t.poses[grain].position);
      else
        EXPECT_EQ(s.centroid, m.centroid);
    }
    // The voxelised centroid is off the true one: the two swaps differ there.
    if (positions) EXPECT_NE(swapped.grains.back().centroid, measured.grains.back().centroid);
  }
}

TEST(Truthswap, BadRequestsAreRefusedInOneSentenceWithNothingWritten) {
  Files f;
  const fs::path out = f.dir / "out.h5";
  const std::string truth_file = f.truth.string(), labels = f.labels.string(), shapes = f.shapes.string();
  test::expect_clean_failure("truthswap", f.dir, {truth_file, shapes, out.string()}, 2, "give it with --labels");
  test::expect_clean_failure("truthswap", f.dir, {truth_file, labels, out.string(), "--positions"}, 2, "drop --positions");
  test::expect_clean_failure("truthswap", f.dir, {truth_file, truth_file, out.string()}, 2, "kind=ground_truth; pass a labels file");
  test::expect_clean_failure("truthswap", f.dir, {labels, labels, out.string()}, 2, "truth_NNN.h5");
  // An empty truth, and an output that is one of the inputs, even with --force.
  const fs::path empty = f.dir / "empty.h5";
  { std::ofstream touch(empty); }
  test::expect_clean_failure("truthswap", f.dir, {empty.string(), labels, out.string()}, 2, "empty.h5");
  test::expect_clean_failure("truthswap", f.dir, {truth_file, shapes, labels, "--labels", labels, "--force"}, 2, "labels.h5");
  // A truth of another scan size.
  synth::GroundTruth other = true_series();
  other.labels = test::label_balls({31, 30, 30}, balls(), Vec3{kVoxel, kVoxel, kVoxel});
  const fs::path other_truth = f.dir / "other_truth.h5";
  synth::write_ground_truth(other_truth, other, {"truth"});
  test::expect_clean_failure("truthswap", f.dir, {other_truth.string(), labels, out.string()}, 1, "differ in shape");
  // An existing output is kept without --force.
  segment::write_labels_file(out, segmented(true_series()), {"the user's"});
  const auto before = fs::last_write_time(out);
  const auto r = run_tool("truthswap", {truth_file, labels, out.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(fs::last_write_time(out), before);
}
