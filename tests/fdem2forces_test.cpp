// fdem2forces: CLI contract; a results file written by the real solver and ResultsWriter (rigid
// boxes on a lattice in affine motion, one grain kicked) with chosen contact forces and grain
// stresses, checked against the exact force PDF fits, rose, strong network, q, volatility and
// D2min, with D2min from the centroids and from tracks2micro's kind=micro file; bad inputs failing
// cleanly.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "graintwin/io/h5file.hpp"
#include "graintwin/micro/forces.hpp"
#include "support/cli_contract.hpp"
#include "support/simulation_results.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

constexpr std::size_t kKicked = 1 + 4 + 16;  // site (1, 1, 1): an interior grain of the 4^3 lattice
constexpr std::size_t kFar = 2 + 2 * 4 + 3 * 16;  // site (2, 2, 3): neither the kicked grain nor its neighbour
constexpr int kSide = 4;
constexpr std::size_t kGrains = kSide * kSide * kSide;
const double kPhiY = 95.0 * std::numbers::pi / 180.0;  // normals of the "y" contacts: azimuth 95 deg, rose bin 9 of 36

test::LatticeRun lattice() {
  test::LatticeRun run;
  run.velocity_gradient << -100, 40, 0, 0, 50, 0, 0, 0, 50;
  run.extra_velocity = {{kKicked, Eigen::Vector3d(3.0, -2.0, 1.0)}};
  return run;
}

double frame_scale(std::size_t k) { return 1.0 + 0.5 * double(k); }
double growth(std::size_t i) { return 0.01 * double(i % 7 + 1); }
/// q of grain i in frame k: its returns ln(q_k / q_{k-1}) = c (2k - 1), so over frames 0..3 the
/// volatility (sample standard deviation of c, 3c, 5c) is exactly 2c.
double grain_q(std::size_t i, std::size_t k) { return 1e5 * double(1 + i) * std::exp(growth(i) * double(k * k)); }

/// Frame k: x-neighbour contacts with normal +x and f_n = s (1..48) N (plus a tangential part),
/// y-neighbour contacts with normals at azimuth 95 deg and f_n = s (49..96) N, one platen contact
/// of 1000 s N that the statistics must leave out; stresses with the q above.
void set_known_frames(const std::filesystem::path& path, std::size_t frames) {
  for (std::size_t k = 0; k < frames; ++k) {
    const double s = frame_scale(k);
    std::vector<test::KnownContact> contacts;
    double f = 1.0;
    for (int z = 0; z < kSide; ++z)
      for (int y = 0; y < kSide; ++y)
        for (int x = 0; x + 1 < kSide; ++x, f += 1.0) {
          const std::size_t a = std::size_t((z * kSide + y) * kSide + x);
          contacts.push_back({a, a + 1, -1, Eigen::Vector3d::UnitX(), s * f * Eigen::Vector3d(1.0, 0.0, 0.3)});
        }
    const Eigen::Vector3d ny(std::cos(kPhiY), std::sin(kPhiY), 0.0);
    for (int z = 0; z < kSide; ++z)
      for (int y = 0; y + 1 < kSide; ++y)
        for (int x = 0; x < kSide; ++x, f += 1.0) {
          const std::size_t a = std::size_t((z * kSide + y) * kSide + x);
          contacts.push_back({a, a + kSide, -1, ny, s * f * ny + Eigen::Vector3d(0.0, 0.0, -0.2 * s * f)});
        }
    contacts.push_back({0, 0, 0, -Eigen::Vector3d::UnitZ(), -1000.0 * s * Eigen::Vector3d::UnitZ()});
    test::set_frame_contacts(path, k, contacts);
    std::vector<Eigen::Matrix3d> stress;
    for (std::size_t i = 0; i < kGrains; ++i) {
      const double q = grain_q(i, k);
      stress.push_back(2e5 * Eigen::Matrix3d::Identity() + Eigen::Vector3d(q, -q, 0.0).asDiagonal().toDenseMatrix());
    }
    test::set_frame_stress(path, k, stress);
  }
}

std::filesystem::path known_results(const test::TempDir& dir) {
  const auto path = dir / "results.h5";
  const test::LatticeRun run = lattice();
  test::write_lattice_results(path, run);
  set_known_frames(path, run.frames);
  return path;
}

double d50() { return std::cbrt(6.0 / std::numbers::pi) * lattice().box; }

}  // namespace

TEST(Fdem2forces, StandardCli) { test::expect_standard_cli("fdem2forces"); }

TEST(Fdem2forces, KnownForcesAndStressesGiveTheExactStatistics) {
  test::TempDir dir;
  const auto results = known_results(dir);
  const auto r = run_tool("fdem2forces", {results.string(), (dir / "forces.h5").string(), "--chains", (dir / "chains").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(dir / "forces.h5");
  EXPECT_EQ(*f.attr_string("/", "kind"), "forces");
  EXPECT_EQ(f.read<std::uint64_t>("/frames/index"), (std::vector<std::uint64_t>{0, 1, 2, 3}));
  EXPECT_EQ(f.read<std::uint64_t>("/frames/contacts"), std::vector<std::uint64_t>(4, 96));
  EXPECT_EQ(f.read<std::uint64_t>("/frames/platen_contacts"), std::vector<std::uint64_t>(4, 1));
  // f = j / 48.5, j = 1..96: strong f >= 1 are j = 49..96, weak j = 1..48.
  double sum_log = 0.0;
  for (int j = 1; j <= 48; ++j) sum_log += std::log(j / 48.5);
  const double scale = 72.5 / 48.5 - 1.0, theta = -1.0 - 48.0 / sum_log;
  const auto mean = f.read<double>("/frames/mean_normal_force");
  const auto strong_scale = f.read<double>("/frames/strong_scale"), weak = f.read<double>("/frames/weak_theta");
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_NEAR(mean[k], 48.5 * frame_scale(k), 1e-9);
    EXPECT_NEAR(strong_scale[k], scale, 1e-12);
    EXPECT_NEAR(weak[k], theta, 1e-12);
  }
  EXPECT_NEAR(f.read<double>("/frames/strong_scale_error")[0], scale / std::sqrt(48.0), 1e-12);
  EXPECT_EQ(f.read<std::uint64_t>("/frames/strong_contacts"), std::vector<std::uint64_t>(4, 48));
  EXPECT_EQ(f.read<std::uint64_t>("/frames/0/pdf/count").size() + 1, f.read<double>("/frames/0/pdf/edges").size());

  // Rose: the x contacts in (theta bin 8, phi bin 0) with mean s x 24.5 N, the y contacts in (8, 9) with s x 72.5 N.
  std::vector<hsize_t> dims;
  const auto count = f.read<std::uint64_t>("/frames/2/rose/count", &dims);
  const auto mean_force = f.read<double>("/frames/2/rose/mean_force");
  ASSERT_EQ(dims, (std::vector<hsize_t>{9, 36}));
  EXPECT_EQ(count[8 * 36 + 0], 48u);
  EXPECT_EQ(count[8 * 36 + 9], 48u);
  EXPECT_NEAR(mean_force[8 * 36 + 0], 24.5 * frame_scale(2), 1e-9);
  EXPECT_NEAR(mean_force[8 * 36 + 9], 72.5 * frame_scale(2), 1e-9);
  EXPECT_TRUE(std::isnan(mean_force[0]));

  // q, its definition, and the volatility 2c over the one window 0 -> 3.
  const auto q = f.read<double>("/grains/q", &dims);
  ASSERT_EQ(dims, (std::vector<hsize_t>{kGrains, 4}));
  for (std::size_t i = 0; i < kGrains; ++i)
    for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(q[i * 4 + k], grain_q(i, k), 1e-9 * grain_q(i, k));
  EXPECT_NE(f.attr_string("/grains/q", "definition")->find("sqrt(1/2 s_ij s_ij)"), std::string::npos);
  EXPECT_EQ(f.read<std::uint64_t>("/windows/from"), std::vector<std::uint64_t>{0});
  EXPECT_EQ(f.read<std::uint64_t>("/windows/to"), std::vector<std::uint64_t>{3});
  const auto vol = f.read<double>("/grains/volatility");
  for (std::size_t i = 0; i < kGrains; ++i) EXPECT_NEAR(vol[i], 2.0 * growth(i), 1e-12) << i;

  // D2min from the centroids: affine motion plus one kicked grain, |delta|^2 / d50^2 for it, 0 far away.
  const double t = 3.0 * double(lattice().steps_per_frame) * lattice().dt;
  const double delta2 = (t * Eigen::Vector3d(3.0, -2.0, 1.0)).squaredNorm();
  const auto d2min = f.read<double>("/grains/d2min");
  EXPECT_NEAR(d2min[kKicked], delta2 / (d50() * d50()), 1e-9 * delta2 / (d50() * d50()));
  EXPECT_NEAR(d2min[kFar], 0.0, 1e-12);
  const micro::Correlation expected = micro::pearson(vol, d2min);
  EXPECT_EQ(f.read<std::uint64_t>("/windows/count")[0], kGrains);
  EXPECT_NEAR(f.read<double>("/windows/pearson_r")[0], expected.r, 1e-12);
  EXPECT_NEAR(f.read<double>("/windows/p_value")[0], expected.p_value, 1e-12);
  EXPECT_EQ(*f.attr_string("/grains/d2min", "source"), "centroids");

  // Force chains: the 48 strong contacts per frame as lines with their forces; a ParaView index of 4 frames.
  const auto chains = test::vtk_summary(dir / "chains" / "chains_000001.vtp");
  EXPECT_EQ(chains["lines"], 48);
  EXPECT_NEAR(chains["cell_data"]["normal_force"]["range"][0].get<double>(), 49.0 * frame_scale(1), 1e-9);
  EXPECT_NEAR(chains["cell_data"]["normal_force"]["range"][1].get<double>(), 96.0 * frame_scale(1), 1e-9);
  std::ifstream pvd(dir / "chains" / "chains.pvd");
  std::stringstream text;
  text << pvd.rdbuf();
  EXPECT_NE(text.str().find("chains_000003.vtp"), std::string::npos);

  // A higher chain threshold keeps fewer: f >= 1.5 <f_n> are j = 73..96.
  const auto high = run_tool("fdem2forces", {results.string(), (dir / "forces_high.h5").string(), "--chain-threshold", "1.5"});
  ASSERT_EQ(high.exit_code, 0) << high.err;
  EXPECT_EQ(io::H5File::open(dir / "forces_high.h5").read<std::uint64_t>("/frames/strong_contacts"), std::vector<std::uint64_t>(4, 24));
}

TEST(Fdem2forces, D2minFromTracks2microMatchesTheCentroids) {
  test::TempDir dir;
  const auto results = known_results(dir);
  const auto micro = run_tool("tracks2micro", {results.string(), (dir / "micro.h5").string(), "--from", "0", "--to", "3"});
  ASSERT_EQ(micro.exit_code, 0) << micro.err;
  ASSERT_EQ(run_tool("fdem2forces", {results.string(), (dir / "a.h5").string()}).exit_code, 0);
  const auto r = run_tool("fdem2forces", {results.string(), (dir / "b.h5").string(), "--micro", (dir / "micro.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File a = io::H5File::open(dir / "a.h5"), b = io::H5File::open(dir / "b.h5");
  const auto da = a.read<double>("/grains/d2min"), db = b.read<double>("/grains/d2min");
  ASSERT_EQ(da.size(), db.size());
  for (std::size_t i = 0; i < da.size(); ++i) EXPECT_NEAR(da[i], db[i], 1e-12);
  EXPECT_NEAR(a.read<double>("/windows/pearson_r")[0], b.read<double>("/windows/pearson_r")[0], 1e-12);
  EXPECT_EQ(*b.attr_string("/grains/d2min", "source"), (dir / "micro.h5").string());
  // Windows of two frames: 0 -> 2 only (2 -> 4 would pass the last frame); the micro file lacks 0 -> 2.
  test::expect_clean_failure("fdem2forces", dir,
                             {results.string(), (dir / "c.h5").string(), "--window", "2", "--micro", (dir / "micro.h5").string()},
                             2, "--from 0 --to 2");
}

TEST(Fdem2forces, BadInputsFailCleanly) {
  test::TempDir dir;
  const auto results = known_results(dir);
  const std::string out = (dir / "forces.h5").string();
  test::expect_clean_failure("fdem2forces", dir, {(dir / "missing.h5").string(), out}, 2, "missing.h5");
  test::expect_clean_failure("fdem2forces", dir, {results.string(), (dir / "forces.txt").string()}, 2, "must end in .h5");
  test::expect_clean_failure("fdem2forces", dir, {results.string(), out, "--window", "1"}, 2, "--window 1");
  test::expect_clean_failure("fdem2forces", dir, {results.string(), out, "--window", "5"}, 2, "smaller window");
  test::expect_clean_failure("fdem2forces", dir, {results.string(), out, "--from", "2", "--to", "9"}, 2, "0..3");

  // Wrong kind: a forces file is not a results file.
  ASSERT_EQ(run_tool("fdem2forces", {results.string(), (dir / "made.h5").string()}).exit_code, 0);
  test::expect_clean_failure("fdem2forces", dir, {(dir / "made.h5").string(), out}, 2, "fdemrun");

  // No frames.
  test::LatticeRun empty = lattice();
  empty.frames = 0;
  test::write_lattice_results(dir / "empty.h5", empty);
  test::expect_clean_failure("fdem2forces", dir, {(dir / "empty.h5").string(), out}, 1, "holds no frames");

  // One frame: no return of q, so no volatility (it said "--from/--to must name two frames" though none was given).
  test::LatticeRun one = lattice();
  one.frames = 1;
  test::write_lattice_results(dir / "one.h5", one);
  set_known_frames(dir / "one.h5", 1);
  test::expect_clean_failure("fdem2forces", dir, {(dir / "one.h5").string(), out}, 1,
                             (dir / "one.h5").string() + " holds a single frame, and the grains' volatility needs two frames or more");

  // Frames straight from the solver without contact: no grain-grain contacts in frame 0.
  test::write_lattice_results(dir / "bare.h5", lattice());
  test::expect_clean_failure("fdem2forces", dir, {(dir / "bare.h5").string(), out}, 1, "frame 0 has no grain-grain contacts");

  // An existing output without --force.
  test::expect_clean_failure("fdem2forces", dir, {results.string(), (dir / "made.h5").string()}, 2, "made.h5");

  // Its own input, by another spelling, even with --force: the input stays as it was.
  const auto size_before = std::filesystem::file_size(results);
  test::expect_clean_failure("fdem2forces", dir,
                             {results.string(), (dir / "." / results.filename()).string(), "--force"}, 2,
                             "is an input of this run");
  EXPECT_EQ(std::filesystem::file_size(results), size_before);
}

TEST(Fdem2forces, ChainsNeverReplaceAFolderItDidNotWrite) {
  // `--chains . --force` once emptied the current folder: a folder no tool wrote is refused, and
  // every file in it stays.
  test::TempDir dir;
  const auto results = known_results(dir);
  std::filesystem::create_directory(dir / "mine");
  std::ofstream(dir / "mine" / "notes.txt") << "mine";
  test::expect_clean_failure("fdem2forces", dir,
                             {results.string(), (dir / "forces.h5").string(), "--chains", (dir / "mine").string(), "--force"},
                             2, "no GrainTwin tool wrote");
  EXPECT_TRUE(std::filesystem::exists(dir / "mine" / "notes.txt"));
  // The folder holding the input (there: the current folder) is refused for that reason first.
  test::expect_clean_failure("fdem2forces", dir,
                             {results.string(), (dir / "forces.h5").string(), "--chains", dir.path().string(), "--force"},
                             2, "holding the input");
  // Its own chains folder is replaced with --force.
  const std::vector<std::string> args{results.string(), (dir / "forces.h5").string(), "--chains", (dir / "chains").string()};
  ASSERT_EQ(run_tool("fdem2forces", args).exit_code, 0);
  std::vector<std::string> again = args;
  again.push_back("--force");
  EXPECT_EQ(run_tool("fdem2forces", again).exit_code, 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "chains" / "chains.pvd"));
}

// NaN passed --chain-threshold; a negative --window wrapped round to 2^64 - 1. Both are refused
// with the range, before the results file is opened.
TEST(Fdem2forces, OptionsOutsideTheirRangeAreRefused) {
  test::TempDir dir;
  const auto results = known_results(dir);
  const std::string out = (dir / "forces.h5").string();
  const auto refused = [&](const std::vector<std::string>& options, const std::string& says) {
    test::expect_option_refused("fdem2forces", dir, {results.string(), out}, options, says);
  };
  refused({"--chain-threshold", "nan"}, "--chain-threshold: must be a finite number in (0, 1000], not nan");
  refused({"--window", "-1"}, "--window: must be a whole number in [0, 1e+09] frames, not -1");
  refused({"--radius-d50", "0"}, "(0, 100] d50");
  refused({"--pdf-bins-per-decade", "nan"}, "[1, 100]");
  refused({"--rose-theta-bins", "1e9"}, "[1, 180]");
}
