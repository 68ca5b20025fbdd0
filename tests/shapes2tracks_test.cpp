// shapes2tracks: CLI contract; tracking the bundled sand_small series (shapes made from its exact
// ground truth, relabelled and shuffled per scan) with identities and rotations checked against
// the truth; the tracks file and its VTK view; bad inputs failing cleanly.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "support/cli_contract.hpp"
#include "support/golden.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

const std::filesystem::path kSeries = std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "sample_volumes" / "sand_small";

/// One truth file as a shapes file: grains shuffled and given labels 1000 + their new row, so
/// neither order nor label carries the identity. true_id[row] = the grain's index in the truth.
struct TruthScan {
  shape::ShapesFile shapes;
  std::vector<std::size_t> true_id;
  std::vector<Eigen::Quaterniond> orientation;  ///< by truth index
};

TruthScan truth_scan(int index, std::uint64_t seed) {
  const io::H5File f = io::H5File::open(kSeries / ("truth_00" + std::to_string(index) + ".h5"));
  const auto centroid = f.read<double>("/grains/centroid"), volume = f.read<double>("/grains/volume"),
             deq = f.read<double>("/grains/equivalent_diameter"), orient = f.read<double>("/grains/orientation");
  std::vector<hsize_t> dims;
  const auto coeffs = f.read<double>("/sh/coeffs", &dims);
  const int degree = int(*f.attr_int("/sh/coeffs", "degree"));
  const std::size_t n = volume.size(), k = dims[1];
  TruthScan t;
  t.true_id.resize(n);
  std::iota(t.true_id.begin(), t.true_id.end(), 0);
  std::mt19937_64 rng(seed);
  std::shuffle(t.true_id.begin(), t.true_id.end(), rng);
  t.shapes.degree = degree;
  std::vector<double> d, v;
  for (std::size_t row = 0; row < n; ++row) {
    const std::size_t i = t.true_id[row];
    shape::GrainShape g;
    g.label = std::uint32_t(1000 + row);
    g.volume = volume[i];
    g.equivalent_diameter = deq[i];
    g.centroid = Eigen::Vector3d(centroid[3 * i], centroid[3 * i + 1], centroid[3 * i + 2]);
    g.coeffs = Eigen::Map<const Eigen::VectorXd>(coeffs.data() + i * k, Eigen::Index(k));
    g.invariants = shape::sh_invariants(g.coeffs, degree);
    g.sh_degree = degree;
    track::inertia_ellipsoid(g.coeffs, degree, g.semi_axes, g.axes);
    t.shapes.grains.push_back(g);
    d.push_back(deq[i]), v.push_back(volume[i]);
  }
  for (std::size_t i = 0; i < n; ++i)
    t.orientation.emplace_back(orient[4 * i], orient[4 * i + 1], orient[4 * i + 2], orient[4 * i + 3]);
  t.shapes.psd = shape::size_distribution(d, v);
  t.shapes.parameters_json = "{}";
  return t;
}

std::vector<TruthScan> write_series(const test::TempDir& dir) {
  std::vector<TruthScan> scans;
  for (int s = 0; s < 3; ++s) {
    scans.push_back(truth_scan(s, 100 + s));
    shape::write_shapes_file(dir / ("shapes_" + std::to_string(s) + ".h5"), scans.back().shapes, {"truth shapes " + std::to_string(s)});
  }
  return scans;
}

std::vector<std::string> series_args(const test::TempDir& dir) {
  return {(dir / "shapes_0.h5").string(), (dir / "shapes_1.h5").string(), (dir / "shapes_2.h5").string()};
}

}  // namespace

TEST(Shapes2tracks, StandardCli) { test::expect_standard_cli("shapes2tracks"); }

TEST(Shapes2tracks, TracksTheBundledSeriesWithTrueIdentitiesAndRotations) {
  test::TempDir dir;
  const auto scans = write_series(dir);
  auto args = series_args(dir);
  args.insert(args.end(), {(dir / "tracks.h5").string(), "--vtk", (dir / "tracks.vtp").string()});
  const auto r = run_tool("shapes2tracks", args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("310 matched (100.0 % of 310), 0 lost"), std::string::npos) << r.err;
  const track::TracksTable t = track::read_tracks_file(dir / "tracks.h5");
  ASSERT_EQ(t.scans, 3u);
  ASSERT_EQ(t.tracks, 310u);
  EXPECT_EQ(t.matched, (std::vector<std::uint64_t>{0, 310, 310}));
  EXPECT_EQ(t.lost, (std::vector<std::uint64_t>{0, 0, 0}));
  EXPECT_EQ(t.started, (std::vector<std::uint64_t>{310, 0, 0}));
  // The positions alone, as the report reads them (no track is lost, so no NaN).
  const track::TrackedCentroids centroids = track::read_tracked_centroids(dir / "tracks.h5");
  EXPECT_EQ(centroids.tracks, t.tracks);
  EXPECT_EQ(centroids.scans, t.scans);
  EXPECT_EQ(centroids.centroid, t.centroid);
  // Each scan's d50 as the matcher measured it from that scan's shapes file.
  ASSERT_EQ(t.scan_d50.size(), 3u);
  for (std::size_t s = 0; s < 3; ++s)
    EXPECT_EQ(t.scan_d50[s], track::scan_grains(shape::read_shapes_file(t.scan_files[s])).d50) << "scan " << s;
  std::vector<double> angle_error;
  std::size_t undefined = 0;
  double confidence = 0.0;
  for (std::size_t i = 0; i < t.tracks; ++i) {
    // Every track must follow one true grain.
    std::size_t ids[3];
    for (std::size_t s = 0; s < 3; ++s) {
      const std::uint32_t label = t.label[i * 3 + s];
      ASSERT_GE(label, 1000u);
      ids[s] = scans[s].true_id[label - 1000];
    }
    EXPECT_EQ(ids[0], ids[1]) << "track " << i;
    EXPECT_EQ(ids[0], ids[2]) << "track " << i;
    for (std::size_t s = 1; s < 3; ++s) {
      const std::size_t c = i * 3 + s;
      EXPECT_GT(t.confidence[c], 0.5) << "track " << i;
      confidence += t.confidence[c];
      // Displacement is the centroid difference.
      for (int q = 0; q < 3; ++q)
        EXPECT_NEAR(t.increment[3 * c + q], t.centroid[3 * c + q] - t.centroid[3 * (c - 1) + q], 1e-15);
      if (!t.rotation_defined[c]) {
        ++undefined;
        continue;
      }
      const Eigen::Quaterniond got(t.rotation_step[4 * c], t.rotation_step[4 * c + 1], t.rotation_step[4 * c + 2],
                                   t.rotation_step[4 * c + 3]);
      const Eigen::Quaterniond truth = scans[s].orientation[ids[s]] * scans[s - 1].orientation[ids[s]].conjugate();
      angle_error.push_back(got.angularDistance(truth) * 180.0 / std::numbers::pi);
    }
  }
  // Exact SH surfaces (the truth's world coefficients are exact rotations of one body): every
  // rotation is defined and recovered to rounding. Noisy surfaces are the library test's business.
  EXPECT_EQ(undefined, 0u);
  ASSERT_EQ(angle_error.size(), 620u);
  EXPECT_LT(*std::max_element(angle_error.begin(), angle_error.end()), 1e-3);
  test::Golden measured("shapes2tracks");
  measured.check("sand_small_mean_confidence", confidence / 620.0);
  measured.check("sand_small_max_rotation_error_deg", *std::max_element(angle_error.begin(), angle_error.end()));
  // The file's provenance and parameters.
  const io::H5File f = io::H5File::open(dir / "tracks.h5");
  const auto history = io::read_history(f);
  EXPECT_EQ(history.front(), "truth shapes 0");
  EXPECT_NE(history.back().find("shapes2tracks"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(t.parameters_json)["method"], "improved");
  // ParaView: one point per track with a displacement vector per step.
  const auto v = test::vtk_summary(dir / "tracks.vtp");
  EXPECT_EQ(v["points"], 310);
  EXPECT_EQ(v["point_data"]["displacement_2"]["components"], 3);
  EXPECT_EQ(v["point_data"]["tracked_1"]["range"][0], 1.0);
}

TEST(Shapes2tracks, PaperMethodAndLostGrains) {
  test::TempDir dir;
  auto scans = write_series(dir);
  // Scan 1 loses its first 5 grains (as if they were merged away): those tracks are lost at step 1
  // and found again in scan 2, not matched to a neighbour.
  scans[1].shapes.grains.erase(scans[1].shapes.grains.begin(), scans[1].shapes.grains.begin() + 5);
  shape::write_shapes_file(dir / "shapes_1.h5", scans[1].shapes, {"truth shapes 1, 5 grains removed"});
  auto args = series_args(dir);
  args.insert(args.end(), {(dir / "tracks.h5").string(), "--rotation", "axes"});
  const auto r = run_tool("shapes2tracks", args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const track::TracksTable t = track::read_tracks_file(dir / "tracks.h5");
  EXPECT_EQ(t.lost[1], 5u);
  EXPECT_EQ(t.found[2], 5u);
  EXPECT_EQ(t.tracks, 310u);
  for (std::size_t i = 0; i < t.tracks; ++i) {
    const std::uint32_t l0 = t.label[i * 3], l2 = t.label[i * 3 + 2];
    EXPECT_EQ(scans[0].true_id[l0 - 1000], scans[2].true_id[l2 - 1000]) << "track " << i;
  }
  // The paper's algorithm runs on the same files (its accuracy is the benchmark's business).
  args.back() = "none";
  args.insert(args.end(), {"--method", "paper", "--force"});
  const auto p = run_tool("shapes2tracks", args);
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_EQ(nlohmann::json::parse(track::read_tracks_file(dir / "tracks.h5").parameters_json)["method"], "paper");
}

TEST(Shapes2tracks, BadInputsFailCleanly) {
  test::TempDir dir;
  write_series(dir);
  const auto a = series_args(dir);
  const std::string out = (dir / "tracks.h5").string();
  const auto fail = [&](const std::vector<std::string>& args, int code, const std::string& words) {
    test::expect_clean_failure("shapes2tracks", dir, args, code, words);
  };
  fail({a[0], out}, 2, "shapes");                                              // one scan only
  fail({a[0], (kSeries / "truth_000.h5").string(), out}, 2, "pass the output of labels2shapes");
  fail({a[0], (dir / "missing.h5").string(), out}, 2, "does not exist");
  fail({a[0], a[1], (dir / "tracks.vtp").string()}, 2, "must end in .h5");
  fail({a[0], a[1], out, "--method", "hungarian"}, 2, "hungarian");
  fail({a[0], a[1], out, "--rotation", "euler"}, 2, "euler");
  fail({a[0], a[1], out, "--vtk", (dir / "t.vtu").string()}, 2, ".vtp");
  fail({a[0], a[1], a[0]}, 2, "also an input");
  ASSERT_EQ(run_tool("shapes2tracks", {a[0], a[1], out}).exit_code, 0);
  fail({a[0], a[1], out}, 2, "--force");
}

// NaN passed the range checks (--volume-tol nan gave no match at all with --method paper): every
// numeric option is now a finite number in a stated range, refused before any table is read.
TEST(Shapes2tracks, OptionsOutsideTheirRangeAreRefused) {
  test::TempDir dir;
  write_series(dir);
  const auto a = series_args(dir);
  const std::string out = (dir / "tracks.h5").string();
  const auto refused = [&](const std::vector<std::string>& options, const std::string& says) {
    test::expect_option_refused("shapes2tracks", dir, {a[0], a[1], out, "--method", "paper"}, options, says);
  };
  refused({"--volume-tol", "nan"}, "--volume-tol: must be a finite number in [-1, 10], not nan");
  refused({"--window", "nan"}, "--window: must be a finite number in (0, 100] d50");
  refused({"--window", "0"}, "(0, 100] d50, not 0");
  refused({"--lost-cost", "inf"}, "--lost-cost");
  refused({"--symmetry-tol", "nan"}, "[0, 0.99]");
  refused({"--rotation-margin", "nan"}, "[1, 100]");
  refused({"--max-gap", "1e9"}, "[0, 100]");
  refused({"--passes", "nan"}, "[1, 10]");
}

TEST(Shapes2tracks, ShapesFileWhoseTablesDisagreeIsRefused) {
  test::TempDir dir;
  auto scans = write_series(dir);
  const auto a = series_args(dir);
  const std::string out = (dir / "tracks.h5").string();
  // A grain label twice: tracks would name one grain for two, and readers by label would pick one.
  shape::ShapesFile twice = scans[1].shapes;
  twice.grains[3].label = twice.grains[2].label;
  shape::write_shapes_file(dir / "twice.h5", twice, {"a label twice"});
  test::expect_clean_failure("shapes2tracks", dir, {a[0], (dir / "twice.h5").string(), out}, 1,
                             (dir / "twice.h5").string() + ": /grains/label names grain 1002 twice; rewrite it with labels2shapes");
  // A size distribution whose columns differ in length.
  shape::ShapesFile psd = scans[1].shapes;
  psd.psd.percent_passing.pop_back();
  shape::write_shapes_file(dir / "psd.h5", psd, {"a short PSD column"});
  test::expect_clean_failure("shapes2tracks", dir, {a[0], (dir / "psd.h5").string(), out}, 1,
                             "/psd/diameter and /psd/percent_passing differ in length");
}
