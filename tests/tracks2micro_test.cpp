// tracks2micro: CLI contract; a lattice series with an exact affine step and then one displaced
// grain (analytic D2min and strain read back from the kind=micro file and its VTK view);
// simulation frames (a kind=fdem_results file from the real solver and ResultsWriter) in affine
// motion giving D2min = 0 and the exact strain; bad inputs failing cleanly.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"
#include "support/simulation_results.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

constexpr int kSide = 6;
constexpr double kSpacing = 0.5e-3;  // = the grains' diameter = d50
const Eigen::Matrix3d kStretch = Eigen::Vector3d(1.002, 1.002, 0.995).asDiagonal();
const Eigen::Vector3d kKick(0.08 * kSpacing, -0.03 * kSpacing, 0.05 * kSpacing);
constexpr std::size_t kKicked = (3 * kSide + 3) * kSide + 2;  // an interior grain
constexpr std::size_t kLoner = kSide * kSide * kSide;          // one grain far from the rest

/// Scan 0: a cubic lattice plus a lone grain; scan 1: stretched by kStretch; scan 2: scan 1 with
/// grain kKicked moved by kKick.
std::vector<std::vector<Eigen::Vector3d>> lattice_states() {
  std::vector<Eigen::Vector3d> p;
  for (int z = 0; z < kSide; ++z)
    for (int y = 0; y < kSide; ++y)
      for (int x = 0; x < kSide; ++x) p.emplace_back(kSpacing * x, kSpacing * y, kSpacing * z);
  p.emplace_back(20 * kSpacing, 20 * kSpacing, 20 * kSpacing);
  std::vector<std::vector<Eigen::Vector3d>> s(3, p);
  for (auto& q : s[1]) q = kStretch * q;
  s[2] = s[1];
  s[2][kKicked] += kKick;
  return s;
}

/// Shapes files (labels 100 + index) and a tracks file following every grain through the states.
std::vector<std::string> write_series(const test::TempDir& dir, const std::vector<std::vector<Eigen::Vector3d>>& states) {
  const std::size_t n = states[0].size(), t = states.size();
  track::TracksFile tf;
  std::vector<std::string> shapes_paths;
  for (std::size_t s = 0; s < t; ++s) {
    std::vector<std::uint32_t> labels;
    for (std::size_t i = 0; i < n; ++i) labels.push_back(std::uint32_t(100 + i));
    shapes_paths.push_back((dir / ("shapes_" + std::to_string(s) + ".h5")).string());
    test::write_sphere_shapes(shapes_paths.back(), labels, states[s], kSpacing, "lattice shapes " + std::to_string(s));
    tf.scans.push_back(shapes_paths.back());
    tf.d50.push_back(kSpacing);
    tf.scan_labels.push_back(labels);
  }
  track::Tracks& tr = tf.tracks;
  tr.scans = t;
  tr.grain.assign(n, std::vector<int>(t));
  tr.confidence.assign(n, std::vector<double>(t, 1.0));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t s = 0; s < t; ++s) tr.grain[i][s] = int(i);
  tr.steps.resize(t);
  tr.diagnostics.resize(t - 1);
  track::Kinematics& k = tf.kinematics;
  k.tracks = n, k.scans = t;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t s = 0; s < t; ++s) {
      const Eigen::Vector3d u = states[s][i] - states[0][i], du = states[s][i] - states[s == 0 ? 0 : s - 1][i];
      for (int q = 0; q < 3; ++q) {
        k.centroid.push_back(states[s][i][q]);
        k.displacement.push_back(u[q]);
        k.increment.push_back(du[q]);
      }
      for (int q = 0; q < 4; ++q) k.rotation.push_back(std::nan("")), k.rotation_step.push_back(std::nan(""));
      k.rotation_misfit.push_back(std::nan(""));
      k.rotation_defined.push_back(0);
    }
  tf.parameters_json = "{}";
  track::write_tracks_file(dir / "tracks.h5", tf, {"lattice tracks"});
  return shapes_paths;
}

bool interior(std::size_t i) {
  if (i >= kLoner) return false;
  const int x = int(i % kSide), y = int(i / kSide % kSide), z = int(i / (kSide * kSide));
  return x > 0 && y > 0 && z > 0 && x < kSide - 1 && y < kSide - 1 && z < kSide - 1;
}

}  // namespace

TEST(Tracks2micro, StandardCli) { test::expect_standard_cli("tracks2micro"); }

TEST(Tracks2micro, LatticeSeriesGivesTheExactStrainAndD2min) {
  test::TempDir dir;
  write_series(dir, lattice_states());
  const auto r = run_tool("tracks2micro", {(dir / "tracks.h5").string(), (dir / "micro.h5").string(), "--vtk",
                                           (dir / "micro.vtp").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(dir / "micro.h5");
  EXPECT_EQ(*f.attr_string("/", "kind"), "micro");
  std::vector<hsize_t> dims;
  const auto d2min = f.read<double>("/grains/d2min", &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{kLoner + 1, 2}));
  const auto strain = f.read<double>("/grains/strain");
  const auto status = f.read<std::uint8_t>("/grains/status");
  const auto cluster = f.read<std::int32_t>("/grains/cluster");
  // Increment 0 -> 1 is affine: no D2min, and the applied strain (compression positive) exactly.
  const double want[6] = {-0.002, -0.002, 0.005, 0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < kLoner; ++i) {
    if (!interior(i)) continue;
    ASSERT_EQ(status[i * 2], 0u) << i;
    EXPECT_LT(d2min[i * 2], 1e-20) << i;
    for (int c = 0; c < 6; ++c) EXPECT_NEAR(strain[(i * 2) * 6 + std::size_t(c)], want[c], 1e-12) << i;
  }
  // Increment 1 -> 2 moves one grain: its neighbourhood (18 neighbours, centrosymmetric) gives
  // D2min = |kick|^2 / d50^2 exactly, and it sits in a cluster with its neighbours.
  EXPECT_NEAR(d2min[kKicked * 2 + 1], kKick.squaredNorm() / (kSpacing * kSpacing), 1e-12);
  const int c = cluster[kKicked * 2 + 1];
  ASSERT_GE(c, 0);
  const auto sizes = f.read<std::uint32_t>("/increments/1/clusters/size");
  EXPECT_GE(sizes.at(std::size_t(c)), 19u);
  // The lone grain has no neighbours: flagged, its values NaN, nowhere in a cluster.
  EXPECT_EQ(status[kLoner * 2], 1u);
  EXPECT_TRUE(std::isnan(d2min[kLoner * 2]));
  EXPECT_EQ(cluster[kLoner * 2 + 1], -1);
  // Per-state structure: the lattice's first g(r) peak at the spacing, coordination 6 inside.
  const auto r0 = f.read<double>("/states/0/rdf/r"), g0 = f.read<double>("/states/0/rdf/g");
  const std::size_t peak = std::size_t(std::max_element(g0.begin(), g0.end()) - g0.begin());
  EXPECT_NEAR(r0[peak], kSpacing, 0.05 * kSpacing / 2.0 + 1e-12);
  const auto z = f.read<std::uint32_t>("/grains/coordination");
  EXPECT_EQ(z[std::size_t(kKicked) * 3], 6u);
  EXPECT_EQ(*f.attr_string("/states/0/coordination", "source"), "distance");
  EXPECT_NEAR(f.attr_doubles("/states/1/psd", "d50").at(0), kSpacing, 1e-12);
  EXPECT_FALSE(f.read<double>("/increments/1/pdf_d2min/density").empty());
  const auto history = io::read_history(f);
  EXPECT_EQ(history.front(), "lattice tracks");
  EXPECT_NE(history.back().find("tracks2micro"), std::string::npos);
  const auto v = test::vtk_summary(dir / "micro.vtp");
  EXPECT_EQ(v["points"], int(kLoner + 1));
  EXPECT_EQ(v["point_data"]["d2min_1"]["components"], 1);
  EXPECT_EQ(v["point_data"]["defined_0"]["range"][0], 0.0);  // the lone grain
}

TEST(Tracks2micro, FromToSpansTwoSteps) {
  test::TempDir dir;
  write_series(dir, lattice_states());
  const auto r = run_tool("tracks2micro", {(dir / "tracks.h5").string(), (dir / "micro.h5").string(), "--from", "0", "--to", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(dir / "micro.h5");
  std::vector<hsize_t> dims;
  const auto d2min = f.read<double>("/grains/d2min", &dims);
  ASSERT_EQ(dims[1], 1u);
  // The affine part is taken out by Lambda: the kick alone remains.
  EXPECT_NEAR(d2min[kKicked], kKick.squaredNorm() / (kSpacing * kSpacing), 1e-12);
  EXPECT_EQ(f.read<std::uint64_t>("/increments/to"), (std::vector<std::uint64_t>{2}));
}

TEST(Tracks2micro, BadInputsFailCleanly) {
  test::TempDir dir;
  const auto shapes = write_series(dir, lattice_states());
  const std::string in = (dir / "tracks.h5").string(), out = (dir / "micro.h5").string();
  const auto fail = [&](const std::vector<std::string>& args, int code, const std::string& words) {
    test::expect_clean_failure("tracks2micro", dir, args, code, words);
  };
  fail({shapes[0], out}, 2, "pass the output of shapes2tracks");
  fail({(dir / "missing.h5").string(), out}, 2, "missing.h5");
  fail({in, (dir / "micro.vtp").string()}, 2, "must end in .h5");
  fail({in, out, "--from", "0"}, 2, "--from and --to go together");
  fail({in, out, "--from", "0", "--to", "7"}, 2, "scans 0..2");
  fail({in, out, "--region", "sphere"}, 2, "sphere");
  fail({in, out, "--shapes", shapes[0], shapes[1]}, 2, "give one per scan");
  fail({in, out, "--shapes", shapes[0], shapes[1], (dir / "gone.h5").string()}, 2, "does not exist");
  fail({in, out, "--shapes", shapes[0], shapes[1], in}, 2, "pass the labels2shapes output");
  // A tracks file of one scan cannot give an increment.
  {
    track::TracksFile one;
    one.scans = {shapes[0]};
    one.d50 = {kSpacing};
    one.scan_labels = {{}};
    one.tracks.scans = 1;
    one.tracks.steps.resize(1);
    one.kinematics.scans = 1;
    one.parameters_json = "{}";
    track::write_tracks_file(dir / "one.h5", one, {"one scan"});
  }
  fail({(dir / "one.h5").string(), out}, 2, "single scan");
  ASSERT_EQ(run_tool("tracks2micro", {in, out}).exit_code, 0);
  fail({in, out}, 2, "--force");
}

TEST(Tracks2micro, TracksFileWithAGrainInTwoTracksIsRefused) {
  test::TempDir dir;
  write_series(dir, lattice_states());
  // Track 1 takes track 0's grain in scan 2: both would get that grain's volume and coordination.
  track::TracksTable t = track::read_tracks_file(dir / "tracks.h5");
  t.label[1 * t.scans + 2] = t.label[0 * t.scans + 2];
  test::replace_dataset(dir / "tracks.h5", schema::tracks::label, t.label, {t.tracks, t.scans});
  test::expect_clean_failure("tracks2micro", dir, {(dir / "tracks.h5").string(), (dir / "micro.h5").string()}, 1,
                             "grain 100 of scan 2 is in two tracks; rewrite it with shapes2tracks");
}

TEST(Tracks2micro, SimulationFramesInAffineMotionGiveTheExactStrain) {
  test::TempDir dir;
  test::LatticeRun run;  // 4^3 rigid boxes 1 mm wide, 1.5 mm apart; frames every 10 us
  run.velocity_gradient << -120, 30, 0, 0, 60, -20, 10, 0, 40;
  const auto results = dir / "results.h5";
  test::write_lattice_results(results, run);
  const auto r = run_tool("tracks2micro", {results.string(), (dir / "micro.h5").string(), "--from", "1", "--to", "3"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Grain positions are x(t) = (I + t L) x0, so the map between frames a and b is F_b F_a^-1.
  std::vector<double> time;
  for (std::size_t k = 0; k < run.frames; ++k) time.push_back(fdem::read_results_frame(results, k).time);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d lambda = (I + time[3] * run.velocity_gradient) * (I + time[1] * run.velocity_gradient).inverse();
  const Eigen::Matrix3d eps = I - 0.5 * (lambda + lambda.transpose());
  const double want[6] = {eps(0, 0), eps(1, 1), eps(2, 2), eps(1, 2), eps(0, 2), eps(0, 1)};
  ASSERT_GT(std::abs(want[0]), 1e-4);
  const io::H5File f = io::H5File::open(dir / "micro.h5");
  std::vector<hsize_t> dims;
  const auto d2min = f.read<double>("/grains/d2min", &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{64, 1}));
  const auto strain = f.read<double>("/grains/strain");
  const auto status = f.read<std::uint8_t>("/grains/status");
  for (std::size_t i = 0; i < 64; ++i) {
    ASSERT_EQ(status[i], 0u) << i;  // every lattice grain has 3 or more neighbours spanning a volume
    EXPECT_LT(d2min[i], 1e-20) << i;
    for (int c = 0; c < 6; ++c) EXPECT_NEAR(strain[i * 6 + std::size_t(c)], want[c], 1e-12) << i;
  }
  // Every grain in every frame, labelled as in the simulation; states are the frames.
  const auto label = f.read<std::uint32_t>("/grains/label", &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{64, 4}));
  EXPECT_EQ(label[5 * 4 + 3], test::lattice_label(5));
  EXPECT_EQ(f.read_strings("/states/file")[2], results.string() + ":/frames/2");
  // d50 from the grains' volumes (equal boxes: the volume-equivalent diameter of one).
  EXPECT_NEAR(f.read<double>("/states/d50")[0], std::cbrt(6.0 / std::numbers::pi) * run.box, 1e-15);
  // Coordination from the frames' contacts: the solver ran without contact, so none.
  EXPECT_EQ(*f.attr_string("/states/0/coordination", "source"), "contacts");
  EXPECT_EQ(f.attr_doubles("/states/0/coordination", "mean").at(0), 0.0);
  EXPECT_NE(f.read_strings("/micro/parameters")[0].find("\"source\":\"fdem_results\""), std::string::npos);

  // Default increments: consecutive frames.
  ASSERT_EQ(run_tool("tracks2micro", {results.string(), (dir / "all.h5").string()}).exit_code, 0);
  EXPECT_EQ(io::H5File::open(dir / "all.h5").read<std::uint64_t>("/increments/from"), (std::vector<std::uint64_t>{0, 1, 2}));

  // Tracks-only options and a single frame fail cleanly.
  test::expect_clean_failure("tracks2micro", dir, {results.string(), (dir / "x.h5").string(), "--contacts", "a.h5", "b.h5"}, 2,
                             "belong to tracks");
  test::expect_clean_failure("tracks2micro", dir, {results.string(), (dir / "x.h5").string(), "--from", "0", "--to", "4"}, 2,
                             "frames 0..3");
  run.frames = 1;
  test::write_lattice_results(dir / "one.h5", run);
  test::expect_clean_failure("tracks2micro", dir, {(dir / "one.h5").string(), (dir / "x.h5").string()}, 2, "single frame");
}

// Every numeric option is a finite number in a stated range (NaN passed CLI11's own ranges), and
// the message prints the range readably.
TEST(Tracks2micro, OptionsOutsideTheirRangeAreRefused) {
  test::TempDir dir;
  write_series(dir, lattice_states());
  const std::string in = (dir / "tracks.h5").string(), out = (dir / "micro.h5").string();
  const auto refused = [&](const std::vector<std::string>& options, const std::string& says) {
    test::expect_option_refused("tracks2micro", dir, {in, out}, options, says);
  };
  refused({"--top-fraction", "nan"}, "--top-fraction: must be a finite number in (0, 1], not nan");
  refused({"--contact-factor", "nan"}, "[0.5, 3]");
  refused({"--pdf-bins-per-decade", "nan"}, "[1, 100]");
  refused({"--radius-d50", "1e400"}, "(0, 100] d50");
  refused({"--displacement-range-d50", "-1"}, "[0, 1000] d50");
  refused({"--rdf-bins", "0"}, "[1, 100000]");
  refused({"--from", "-1", "--to", "1"}, "--from: must be a whole number in [0, 1e+09]");
}
