// validate: CLI contract; a tiny ctsynth-like series with exact truth (three scans of a 4 x 4 x 4
// lattice of balls under a small axial strain) whose run is made by the real tools from label
// images with a known defect (two touching balls merged in scan 1), scored to the exact counts
// that defect implies; a simulated truth whose twin is 10 % stiffer scored to an RMS of 0.1; bad
// inputs refused in one sentence with nothing written.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <numbers>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using test::run_tool;
namespace fs = std::filesystem;

namespace {

constexpr int kScans = 3;
constexpr int kGrains = 64;
constexpr double kVoxel = 1e-5;
constexpr double kCentre = 7.0 + 1.5 * 11.0;
/// The two balls merged in scan 1's segmentation: lattice neighbours along x.
constexpr std::uint32_t kMergedA = 22, kMergedB = 23;

/// Scan t's balls: a 4 x 4 x 4 lattice 11 voxels apart (radius 5.6: neighbours overlap by 0.2
/// voxel), shortened along z by 1 % per scan with a small non-affine nudge per ball.
std::vector<test::Ball> scan_balls(int t) {
  std::vector<test::Ball> balls = test::jittered_lattice(4, 5.6, 11.0, 7.0, 0.0, 0.0, 1);
  for (std::size_t i = 0; i < balls.size(); ++i) {
    test::Ball& b = balls[i];
    b.z = kCentre + (b.z - kCentre) * (1.0 - 0.01 * t) + 0.1 * t * std::sin(1.7 * double(i));
    b.y += 0.1 * t * std::cos(2.3 * double(i));
  }
  return balls;
}

Eigen::Vector3d position(const test::Ball& b) { return kVoxel * Eigen::Vector3d(b.x, b.y, b.z); }

synth::GroundTruth truth_of(int t, bool simulated) {
  const auto balls = scan_balls(t);
  synth::GroundTruth g;
  g.scan_index = t, g.axial_strain = 0.01 * t, g.sample_height = 48 * kVoxel, g.sample_radius = 24 * kVoxel;
  g.labels = test::label_balls({48, 48, 48}, balls, Vec3{kVoxel, kVoxel, kVoxel});
  g.sh_degree = 2;
  g.sh_coeffs = g.sh_coeffs_body = Eigen::MatrixXd::Zero(kGrains, 9);
  g.sh_invariants = Eigen::MatrixXd::Zero(kGrains, 3);
  for (int i = 0; i < kGrains; ++i) {
    const double r = balls[i].r * kVoxel;
    g.poses.push_back({position(balls[i]), Eigen::Quaterniond::Identity()});
    g.volume.push_back(4.0 / 3.0 * std::numbers::pi * r * r * r);
    g.equivalent_diameter.push_back(2 * r), g.sphericity.push_back(1.0), g.aspect_ratio.push_back(1.0);
    g.sh_coeffs(i, 0) = g.sh_coeffs_body(i, 0) = g.sh_invariants(i, 0) = r * std::sqrt(4 * std::numbers::pi);
    for (int j = i + 1; j < kGrains; ++j) {
      const Eigen::Vector3d d = position(balls[j]) - position(balls[i]);
      const double overlap = (balls[i].r + balls[j].r) * kVoxel - d.norm();
      if (overlap > -2 * kVoxel)
        g.contacts.push_back({std::uint32_t(i + 1), std::uint32_t(j + 1), overlap, position(balls[i]) + 0.5 * d, d.normalized(),
                              overlap > -0.5 * kVoxel});
    }
  }
  if (simulated) {
    g.simulated = true;
    g.contact_force.assign(g.contacts.size(), Eigen::Vector3d::Zero());
    g.stress_ratio = 2.0, g.volumetric_strain = 0.0;
    for (int k = 0; k <= 20; ++k) {
      const double e = 0.005 * k;
      g.loading_curve.axial_strain.push_back(e), g.loading_curve.stress_ratio.push_back(2.0 + 50 * e);
      g.loading_curve.volumetric_strain.push_back(0.1 * e);
    }
  }
  return g;
}

/// The segmentation of scan t: the true labels, except in scan 1 where kMergedB joins kMergedA.
void write_labels(const fs::path& path, const synth::GroundTruth& truth, int t) {
  segment::LabelsFile c;
  c.labels = truth.labels;
  if (t == 1)
    for (std::uint32_t& v : c.labels.values()) v = v == kMergedB ? kMergedA : (v > kMergedB ? v - 1 : v);
  c.grains = segment::grain_table(c.labels);
  std::size_t solid = 0;
  for (std::uint32_t v : c.labels.values()) solid += v != 0;
  c.sample.region.radius = std::numeric_limits<double>::infinity();
  const double voxel = kVoxel * kVoxel * kVoxel;
  c.sample.void_ratio = {double(solid) * voxel, double(c.labels.size() - solid) * voxel,
                         double(c.labels.size() - solid) / double(solid)};
  c.parameters_json = "{}";
  segment::write_labels_file(path, c, {"phantom labels of scan " + std::to_string(t)});
}

void run_ok(const std::string& tool, const std::vector<std::string>& args) {
  const auto r = run_tool(tool, args);
  ASSERT_EQ(r.exit_code, 0) << tool << ": " << r.err;
}

struct Series {
  test::TempDir dir;
  fs::path prescribed, simulated, run, twin_run;
};
Series* g_series = nullptr;

void make_series() {
  g_series = new Series;
  Series& s = *g_series;
  s.prescribed = s.dir / "prescribed", s.simulated = s.dir / "simulated", s.run = s.dir / "run", s.twin_run = s.dir / "twin_run";
  std::vector<std::string> shapes, contacts;
  for (int t = 0; t < kScans; ++t) {
    const std::string n = "00" + std::to_string(t);
    fs::create_directories(s.prescribed), fs::create_directories(s.simulated);
    const synth::GroundTruth truth = truth_of(t, false);
    synth::write_ground_truth(s.prescribed / ("truth_" + n + ".h5"), truth, {"truth"});
    synth::write_ground_truth(s.simulated / ("truth_" + n + ".h5"), truth_of(t, true), {"truth"});
    const fs::path scan = s.run / ("scan_" + n);
    fs::create_directories(scan);
    write_labels(scan / "labels.h5", truth, t);
    run_ok("labels2contacts", {(scan / "labels.h5").string(), (scan / "contacts.h5").string()});
    run_ok("labels2shapes", {(scan / "labels.h5").string(), (scan / "shapes.h5").string(), "--degree", "6"});
    shapes.push_back((scan / "shapes.h5").string());
    contacts.push_back((scan / "contacts.h5").string());
  }
  std::vector<std::string> track_args = shapes;
  track_args.insert(track_args.end(), {(s.run / "tracks.h5").string(), "--rotation", "axes"});
  run_ok("shapes2tracks", track_args);
  std::vector<std::string> micro_args{(s.run / "tracks.h5").string(), (s.run / "micro.h5").string(), "--contacts"};
  micro_args.insert(micro_args.end(), contacts.begin(), contacts.end());
  run_ok("tracks2micro", micro_args);
  // The twin: a results file whose shearing curve is the truth's stress ratio x 1.1 up to 6 %,
  // its volumetric strain 0.002 above the truth's.
  fs::copy(s.run, s.twin_run, fs::copy_options::recursive);
  const fs::path sim = s.twin_run / "simulation.h5";
  test::write_lattice_results(sim, test::LatticeRun{});
  const std::size_t rows = io::H5File::open(sim).read<double>(schema::fdem_results::series_time).size();
  std::vector<double> axial, ratio, volumetric;
  for (std::size_t r = 0; r < rows; ++r) {
    const double e = 0.06 * double(r) / double(rows - 1);
    axial.push_back(e), ratio.push_back(1.1 * (2.0 + 50 * e)), volumetric.push_back(0.1 * e + 0.002);
  }
  namespace sr = schema::fdem_results;
  test::replace_dataset(sim, sr::series_axial_strain, axial, {rows});
  test::replace_dataset(sim, sr::series_volumetric_strain, volumetric, {rows});
  test::replace_dataset(sim, sr::series_stress_ratio, ratio, {rows});
}

class Validate : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!g_series) make_series();
  }
  static void TearDownTestSuite() {
    delete g_series;
    g_series = nullptr;
  }
};

nlohmann::json validate_ok(const fs::path& run, const fs::path& series, const fs::path& out) {
  const auto r = run_tool("validate", {run.string(), series.string(), out.string(), "--force"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out);
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(ValidateCli, StandardOptions) { test::expect_standard_cli("validate"); }

TEST_F(Validate, AMergedPairIsScoredExactlyThroughEveryLine) {
  const nlohmann::json j = validate_ok(g_series->run, g_series->prescribed, g_series->dir / "v.json");
  // Segmentation: every ball right but the merged two in scan 1.
  const auto& seg = j["segmentation"]["scans"];
  ASSERT_EQ(seg.size(), 3u);
  EXPECT_EQ(seg[0]["right"], kGrains);
  EXPECT_EQ(seg[1]["right"], kGrains - 2);
  EXPECT_EQ(seg[1]["merged"], 2);
  EXPECT_EQ(seg[1]["labels"], kGrains - 1);
  EXPECT_EQ(seg[2]["right"], kGrains);
  EXPECT_DOUBLE_EQ(j["segmentation"]["grains_right"].get<double>(), (3.0 * kGrains - 2) / (3.0 * kGrains));
  // The same voxels counted in the same region: the void ratios agree exactly.
  EXPECT_DOUBLE_EQ(seg[0]["void_ratio"].get<double>(), seg[0]["void_ratio_true"].get<double>());
  // Contacts: the lattice's 144 touching neighbours in scan 0, all found, none false; in scan 1
  // the merged pair's contacts are between grains that are not faithful and are not counted.
  const auto& con = j["contacts"]["scans"];
  EXPECT_EQ(con[0]["true_touching"], 144);
  EXPECT_EQ(con[0]["found"], 144);
  EXPECT_EQ(con[0]["false"], 0);
  EXPECT_LT(con[0]["normal_error_median_deg"].get<double>(), 10.0);
  EXPECT_LT(con[1]["true_touching"].get<int>(), 144);
  // Shapes: the voxel balls' volumes within a few per cent of the true ones.
  EXPECT_LT(std::abs(j["shapes"]["volume_error_median"].get<double>()), 0.05);
  // Tracking: the merged pair is no target in either increment; every other ball is tracked right.
  const auto& tr = j["tracking"]["increments"];
  ASSERT_EQ(tr.size(), 2u);
  for (const auto& t : tr) {
    EXPECT_EQ(t["targets"], kGrains - 2);
    EXPECT_EQ(t["right"], kGrains - 2);
    EXPECT_EQ(t["wrong"], 0);
    EXPECT_EQ(t["lost"], 0);
    EXPECT_LT(t["displacement_error_median_m"].get<double>(), 0.2 * kVoxel);
  }
  EXPECT_EQ(j["tracking"]["right"], 2 * (kGrains - 2));
  // D2min of the voxel centroids follows the truth's: a strong rank correlation.
  ASSERT_EQ(j["d2min"]["increments"].size(), 2u);
  EXPECT_GT(j["d2min"]["spearman"].get<double>(), 0.5);
  // Prescribed loading: the twin line says so and holds nulls.
  EXPECT_EQ(j["twin"]["simulated"], false);
  EXPECT_TRUE(j["twin"]["stress_ratio_rms_rel"].is_null());
  EXPECT_FALSE(j["history"].empty());
  EXPECT_NE(j["history"].back().get<std::string>().find("validate"), std::string::npos);
}

TEST_F(Validate, TheTwinIsScoredAgainstTheTruthsLoadingCurve) {
  const nlohmann::json j = validate_ok(g_series->twin_run, g_series->simulated, g_series->dir / "twin.json");
  const auto& twin = j["twin"];
  EXPECT_EQ(twin["simulated"], true);
  EXPECT_NEAR(twin["stress_ratio_rms_rel"].get<double>(), 0.1, 1e-9);
  EXPECT_NEAR(twin["volumetric_strain_max_abs"].get<double>(), 0.002, 1e-9);
  EXPECT_NEAR(twin["axial_strain_max"].get<double>(), 0.06, 1e-9);
}

TEST_F(Validate, BadInputsAreRefusedWithNothingWritten) {
  test::TempDir out;
  const std::string json = (out / "v.json").string();
  // A series without truth files (the run folder itself).
  test::expect_clean_failure("validate", out, {g_series->run.string(), g_series->run.string(), json}, 2, "truth_000.h5");
  test::expect_clean_failure("validate", out, {(g_series->dir / "none").string(), g_series->prescribed.string(), json}, 2,
                             "is not a folder");
  test::expect_clean_failure("validate", out, {g_series->run.string(), g_series->prescribed.string(), (out / "v.txt").string()}, 2,
                             "must end in .json");
  // A truth file of the wrong kind.
  test::TempDir wrong;
  for (int t = 0; t < kScans; ++t)
    fs::copy_file(g_series->run / ("scan_00" + std::to_string(t)) / "labels.h5", wrong / ("truth_00" + std::to_string(t) + ".h5"));
  test::expect_clean_failure("validate", out, {g_series->run.string(), wrong.path().string(), json}, 2, "ground_truth");
  // A truncated truth file, and one whose poses hold a NaN.
  test::TempDir damaged;
  for (int t = 0; t < kScans; ++t) {
    const std::string name = "truth_00" + std::to_string(t) + ".h5";
    fs::copy_file(g_series->prescribed / name, damaged / name);
  }
  const fs::path first = damaged / "truth_000.h5";
  fs::resize_file(first, fs::file_size(first) / 2);
  test::expect_clean_failure("validate", out, {g_series->run.string(), damaged.path().string(), json}, 1, "truncated");
  fs::copy_file(g_series->prescribed / "truth_000.h5", first, fs::copy_options::overwrite_existing);
  auto centroid = io::H5File::open(first).read<double>(schema::ground_truth::grain_centroid);
  centroid[3] = std::nan("");
  test::replace_dataset(first, schema::ground_truth::grain_centroid, centroid, {centroid.size() / 3, 3});
  test::expect_clean_failure("validate", out, {g_series->run.string(), damaged.path().string(), json}, 1, "NaN");
  // An existing output without --force.
  std::ofstream(json) << "{}";
  test::expect_clean_failure("validate", out, {g_series->run.string(), g_series->prescribed.string(), json}, 2, "--force");
}
