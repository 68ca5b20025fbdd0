// report: CLI contract; a tiny run made with the real tools (three labelled phantom scans under a
// known axial strain through labels2contacts, labels2shapes, shapes2tracks and tracks2micro; a
// simulation written by the real solver and ResultsWriter with chosen contacts, stresses and
// triaxial series through tracks2micro and fdem2forces) rendered into one page that names every
// panel, embeds every chart, keeps the PNGs and the exact numbers; the page rendered in headless
// Chromium with every image decoded; the error budget of a validation.json, one line per item with
// its number and chart, and one sentence without it; a run without simulation saying so per panel;
// bad inputs failing cleanly. The report module's helpers are tested in libcommon/report_charts_test.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/report/charts.hpp"
#include "graintwin/report/error_budget.hpp"
#include "graintwin/report/page.hpp"
#include "graintwin/report/run_data.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "graintwin/validate/validation_file.hpp"
#include "support/cli_contract.hpp"
#include "support/cube_sample.hpp"
#include "support/processes.hpp"
#include "support/phantoms.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using test::run_tool;
namespace fs = std::filesystem;

namespace {

constexpr int kScans = 3;
constexpr double kAxialStep = 0.02;    // each scan shortens z by 2 % of the first scan's length
constexpr double kLateralStep = 0.004;  // and widens x and y by 0.4 %
constexpr double kCentre = 7.0 + 1.5 * 11.0;
constexpr std::size_t kRows = 30;       // series rows of the lattice simulation (3 frame steps x 10)

double applied_axial_strain(int scan) { return -std::log(1.0 - kAxialStep * scan); }

/// The balls of scan t: a jittered 4 x 4 x 4 lattice, compressed along z and widened in x, y
/// about the lattice centre, each ball nudged a little off the affine map (non-affine motion).
std::vector<test::Ball> scan_balls(int t) {
  std::vector<test::Ball> balls = test::jittered_lattice(4, 5.6, 11.0, 7.0, 0.3, 0.05, 11);
  for (std::size_t i = 0; i < balls.size(); ++i) {
    test::Ball& b = balls[i];
    b.z = kCentre + (b.z - kCentre) * (1.0 - kAxialStep * t) + 0.15 * t * std::sin(1.7 * double(i));
    b.y = kCentre + (b.y - kCentre) * (1.0 + kLateralStep * t) + 0.15 * t * std::cos(2.3 * double(i));
    b.x = kCentre + (b.x - kCentre) * (1.0 + kLateralStep * t);
  }
  return balls;
}

/// The label image of scan t, placed where the lattice simulation's cubes are (11 voxels per 1.5 mm
/// site spacing, the lattice's first ball centre at its first site), as a pipeline's twin is built
/// at its reference scan's positions. Longer in y, so the vertical plane through the image's middle
/// (y = 19.5 voxels) runs through the third row of balls and of cubes, not between rows.
Volume<std::uint32_t> scan_labels(int t) {
  constexpr double kVoxel = 1.5e-3 / 11.0;
  Volume<std::uint32_t> labels = test::label_balls({48, 54, 48}, scan_balls(t), {kVoxel, kVoxel, kVoxel});
  labels.set_origin({-7.0 * kVoxel, -7.0 * kVoxel, -7.0 * kVoxel});
  return labels;
}

void write_labels(const fs::path& path, int t) {
  segment::LabelsFile c;
  c.labels = scan_labels(t);
  c.grains = segment::grain_table(c.labels);
  std::size_t solid = 0;
  for (std::uint32_t v : c.labels.values()) solid += v != 0;
  const double voxel = 1e-15;
  c.sample.region.radius = std::nan("");
  c.sample.void_ratio = {double(solid) * voxel, double(c.labels.size() - solid) * voxel,
                         double(c.labels.size() - solid) / double(solid)};
  c.parameters_json = "{}";
  segment::write_labels_file(path, c, {"phantom labels of scan " + std::to_string(t)});
}

/// Scan t itself (kind=volume): grey values of its labels' geometry, bright grains in a darker
/// ground with a gentle ramp, so the sections have grey under the labels.
void write_scan(const fs::path& path, int t) {
  const Volume<std::uint32_t> labels = scan_labels(t);
  Volume<std::uint8_t> grey(labels.shape(), labels.voxel_size(), labels.origin());
  const auto [nz, ny, nx] = labels.shape();
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x) grey(z, y, x) = std::uint8_t((labels(z, y, x) ? 170 : 40) + (x + y) % 16);
  io::write_volume_file(path, AnyVolume(std::move(grey)), {"phantom scan " + std::to_string(t)});
}

/// The simulation's triaxial series: eps_1 from 0 to 6 %, dilation, a hardening stress ratio.
std::vector<double> sim_axial() {
  std::vector<double> v;
  for (std::size_t r = 0; r < kRows; ++r) v.push_back(0.06 * double(r) / double(kRows - 1));
  return v;
}
double sim_ratio(double eps) { return 1.0 + 3.0 * eps / (0.01 + eps); }

/// Frame k's membrane: `balls` (x, y, z each) as /frames/<k>/membrane/position, where fdemrun's
/// triaxial test writes its balls.
void add_membrane(const fs::path& path, std::size_t k, const std::vector<double>& balls) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::string group = fmt::format("/frames/{:06d}/membrane", k);
  const hid_t g = H5Gcreate2(file, group.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hsize_t dims[2] = {balls.size() / 3, 3};
  const hid_t space = H5Screate_simple(2, dims, nullptr);
  const hid_t set = H5Dcreate2(g, "position", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const herr_t written = H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, balls.data());
  H5Dclose(set), H5Sclose(space), H5Gclose(g), H5Fclose(file);
  ASSERT_GE(written, 0);
}

/// A 4^3 lattice of rigid boxes compressed along z, with x- and z-neighbour contacts carrying
/// spread-out forces, grain stresses whose q varies from frame to frame, the triaxial series, and a
/// membrane of balls on a cylinder around the lattice; its frames also as fdemrun --vtk writes them.
void write_simulation(const fs::path& path) {
  test::LatticeRun run;
  run.velocity_gradient = Eigen::Vector3d(20.0, 20.0, -100.0).asDiagonal();
  run.extra_velocity = {{21, Eigen::Vector3d(2.0, -1.0, 1.0)}};
  run.vtk_frames = path.parent_path() / "simulation_frames";
  test::write_lattice_results(path, run);
  const std::size_t n = 64;
  for (std::size_t k = 0; k < run.frames; ++k) {
    std::vector<double> balls;
    for (int ring = 0; ring < 8; ++ring)
      for (int j = 0; j < 24; ++j) {
        const double phi = 2.0 * std::numbers::pi * j / 24.0;
        balls.insert(balls.end(), {2.25e-3 + 3.6e-3 * std::cos(phi), 2.25e-3 + 3.6e-3 * std::sin(phi), -0.5e-3 + 0.7e-3 * ring});
      }
    add_membrane(path, k, balls);
    std::vector<test::KnownContact> contacts;
    double f = 1.0;
    for (std::size_t a = 0; a < n; ++a) {
      if (a % 4 + 1 < 4) contacts.push_back({a, a + 1, -1, Eigen::Vector3d::UnitX(), (1.0 + k) * f * Eigen::Vector3d::UnitX()}), f *= 1.07;
      if (a + 16 < n) contacts.push_back({a, a + 16, -1, Eigen::Vector3d::UnitZ(), (2.0 + k) * f * Eigen::Vector3d::UnitZ()}), f *= 1.05;
      if (f > 40.0) f = 0.5;
    }
    test::set_frame_contacts(path, k, contacts);
    std::vector<Eigen::Matrix3d> stress;
    for (std::size_t i = 0; i < n; ++i) {
      const double q = 1e5 * double(1 + i) * std::exp(0.01 * double(i % 5 + 1) * double(k * k));
      stress.push_back(2e5 * Eigen::Matrix3d::Identity() + Eigen::Vector3d(q, -q, 0.0).asDiagonal().toDenseMatrix());
    }
    test::set_frame_stress(path, k, stress);
  }
  std::vector<double> axial = sim_axial(), volumetric, ratio;
  for (double e : axial) volumetric.push_back(0.3 * e - 8.0 * e * e), ratio.push_back(sim_ratio(e));
  namespace sr = schema::fdem_results;
  test::replace_dataset(path, sr::series_axial_strain, axial, {kRows});
  test::replace_dataset(path, sr::series_volumetric_strain, volumetric, {kRows});
  test::replace_dataset(path, sr::series_stress_ratio, ratio, {kRows});
}

/// An error budget with every line filled: three scans, two increments, a simulated truth's twin.
void write_budget(const fs::path& path) {
  validate::Validation v;
  v.run = "full", v.series = "phantom";
  for (int t = 0; t < kScans; ++t) {
    validate::ScanValidation sc;
    sc.name = "scan_00" + std::to_string(t);
    sc.segmentation.true_grains = 64, sc.segmentation.right = 62 + t % 2, sc.segmentation.merged = 2 - 2 * (t % 2);
    sc.segmentation.void_ratio = 0.7 + 0.01 * t, sc.segmentation.void_ratio_true = 0.69 + 0.01 * t;
    sc.has_contacts = sc.has_shapes = true;
    sc.contacts.true_touching = 144, sc.contacts.found = 140, sc.contacts.missed = 4, sc.contacts.false_found = 1;
    sc.contacts.normal_error_deg = {1.0, 2.0, 4.0, 8.0};
    sc.contacts.anisotropy = 0.1 * t, sc.contacts.anisotropy_true = 0.1 * t + 0.02;
    sc.shapes.invariant_error_by_degree = {0.01, 0.5, 0.05, 0.08};
    sc.shapes.invariant_error_median = 0.06;
    sc.shapes.volume_error = {-0.03, -0.01, 0.02};
    v.scans.push_back(sc);
  }
  for (std::size_t k = 1; k < std::size_t(kScans); ++k) {
    validate::TrackingScore t;
    t.from = k - 1, t.to = k, t.targets = 62, t.right = 61, t.wrong = 1;
    t.displacement_error_m = {1e-6, 2e-6, 3e-6}, t.rotation_error_deg = {1.0, 5.0};
    v.tracking.push_back(t);
    validate::DeformationScore d;
    d.from = k - 1, d.to = k, d.d2min = {0.01, 0.02, 0.05}, d.d2min_true = {0.012, 0.018, 0.06};
    d.d2min_spearman = 1.0, d.cluster_members = 6, d.cluster_members_true = 7, d.cluster_common = 5, d.cluster_jaccard = 5.0 / 8.0;
    v.deformation.push_back(d);
  }
  v.has_simulation = true;
  v.twin.simulated = true;
  v.twin.axial_strain = {0.0, 0.01, 0.02}, v.twin.stress_ratio_true = {1.0, 2.0, 2.5}, v.twin.stress_ratio = {1.0, 2.2, 2.6};
  v.twin.volumetric_strain_true = v.twin.volumetric_strain = {0.0, 0.0, 0.0};
  v.twin.stress_ratio_rms_rel = 0.06;
  v.history = {"validate of the phantom run"};
  validate::write_validation(path, v);
}

/// The lines of the error budget, in page order.
const std::vector<std::string> kBudgetLines{"segmentation", "void_ratio", "contacts", "normals", "fabric", "invariants", "volume",
                                            "tracking", "displacement", "rotation", "d2min", "clusters", "twin"};

void run_ok(const std::string& tool, const std::vector<std::string>& args) {
  const auto r = run_tool(tool, args);
  ASSERT_EQ(r.exit_code, 0) << tool << ": " << r.err;
}

/// The run every test reads: `full` has both sides, `experiment` the scans only.
struct Runs {
  test::TempDir dir;
  fs::path full, experiment, series_json;
  std::vector<std::string> volumes;  ///< the scans themselves, outside the run (as the series' are)
  fs::path page;           ///< the report of `full` with --scan-strains
  test::ToolResult made;   ///< how making it went
};

Runs* g_runs = nullptr;

void make_runs() {
  g_runs = new Runs;
  Runs& r = *g_runs;
  r.full = r.dir / "full", r.experiment = r.dir / "experiment";
  std::vector<std::string> shapes, contacts;
  nlohmann::json series = {{"scans", nlohmann::json::array()}};
  for (int t = 0; t < kScans; ++t) {
    const fs::path scan = r.full / ("scan_00" + std::to_string(t));
    fs::create_directories(scan);
    write_labels(scan / "labels.h5", t);
    r.volumes.push_back((r.dir / ("scan_00" + std::to_string(t) + ".h5")).string());
    write_scan(r.volumes.back(), t);
    run_ok("labels2contacts", {(scan / "labels.h5").string(), (scan / "contacts.h5").string()});
    // Low SH degree and principal-axis rotations: the report reads no shape detail, and it is faster.
    run_ok("labels2shapes", {(scan / "labels.h5").string(), (scan / "shapes.h5").string(), "--degree", "6", "--surfaces",
                             (scan / "grains.vtp").string()});
    shapes.push_back((scan / "shapes.h5").string());
    contacts.push_back((scan / "contacts.h5").string());
    series["scans"].push_back({{"axial_strain", applied_axial_strain(t)}});
  }
  std::vector<std::string> track_args = shapes;
  track_args.insert(track_args.end(), {(r.full / "tracks.h5").string(), "--rotation", "axes", "--vtk", (r.full / "tracks.vtp").string()});
  run_ok("shapes2tracks", track_args);
  std::vector<std::string> micro_args{(r.full / "tracks.h5").string(), (r.full / "micro.h5").string(), "--contacts"};
  micro_args.insert(micro_args.end(), contacts.begin(), contacts.end());
  run_ok("tracks2micro", micro_args);
  fs::copy(r.full, r.experiment, fs::copy_options::recursive);
  write_simulation(r.full / "simulation.h5");
  fdem::write_model_file(r.full / "model.h5", test::lattice_model({}), {"the lattice's model (test)"});
  write_budget(r.full / "validation.json");
  // The boxes sit 1.5 mm apart with equivalent radii of 0.62 mm: link neighbours into clusters.
  run_ok("tracks2micro", {(r.full / "simulation.h5").string(), (r.full / "simulation_micro.h5").string(), "--contact-factor", "1.3"});
  run_ok("fdem2forces", {(r.full / "simulation.h5").string(), (r.full / "forces.h5").string(), "--chains", (r.full / "force_chains").string()});
  r.series_json = r.dir / "series.json";
  std::ofstream(r.series_json) << series.dump();
}

/// The report of the full run with --scan-strains, made on first use (ctest runs each test in its
/// own process, so only the tests that read it pay for it).
const test::ToolResult& full_report() {
  Runs& r = *g_runs;
  if (r.page.empty()) {
    fs::create_directories(r.dir / "out");
    r.page = r.dir / "out/report.html";
    std::vector<std::string> args{r.full.string(), r.page.string(), "--scan-strains", r.series_json.string(), "--volumes"};
    args.insert(args.end(), r.volumes.begin(), r.volumes.end());
    r.made = run_tool("report", args);
  }
  return r.made;
}

class Report : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!g_runs) make_runs();
  }
  static void TearDownTestSuite() {
    delete g_runs;
    g_runs = nullptr;
  }
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

const nlohmann::json* find_chart(const nlohmann::json& spec, const std::string& file) {
  for (const auto& c : spec["charts"])
    if (c["file"] == file) return &c;
  return nullptr;
}

const nlohmann::json* find_series(const nlohmann::json& chart, const std::string& name) {
  for (const auto& s : chart["series"])
    if (s["name"] == name) return &s;
  return nullptr;
}

const std::vector<std::string> kPanels{"stress_ratio", "volumetric_strain", "psd",  "coordination", "rose_normals",
                                        "rose_branches", "rose_forces", "rdf", "displacement", "d2min_pdf",
                                        "eps_q_pdf", "cluster_sizes", "cluster_rg", "force_pdf", "volatility"};

/// The section panels of the full run: one per scan, then D2min and eps_q for each increment (the
/// scans have two, the simulation's four frames three).
const std::vector<std::string> kSectionPanels{"section_scan_000", "section_scan_001", "section_scan_002",
                                              "section_d2min_0",  "section_d2min_1",  "section_d2min_2",
                                              "section_eps_q_0",  "section_eps_q_1",  "section_eps_q_2"};
/// Section sides without a picture in the full run: the third increment exists in the simulation only.
constexpr std::size_t kSectionSidesMissing = 2;
/// The D2min clusters in 3D: one panel per increment, the scans' two beside the simulation's three.
const std::vector<std::string> kClusterPanels{"clusters_3d_0", "clusters_3d_1", "clusters_3d_2"};
/// eps_q in 3D: one panel per increment, as the D2min clusters.
const std::vector<std::string> kEpsQPanels{"eps_q_3d_0", "eps_q_3d_1", "eps_q_3d_2"};
/// The grains' surfaces in 3D: one panel, the reference scan beside the twin's last frame.
constexpr std::size_t kSurfacePictures = 2;
/// The force-chain network's panels: one per frame of the lattice simulation, the simulation's side only.
const std::vector<std::string> kNetworkPanels{"force_network_0", "force_network_1", "force_network_2", "force_network_3"};

/// The pixel check of the pictures of the sample (sections, the 3D grains, clusters, eps_q and force networks), run with
/// Debian's Python: each must show something (not
/// blank, many colours, at least 2 % of it grains in colour) with the sample inside the frame (the
/// coloured pixels away from the picture's edges, their centre in its middle). Prints one line per
/// failure and the count checked.
constexpr const char* kPixelCheck = R"(
import json, sys
import matplotlib.image as mi
import numpy as np
folder = sys.argv[1]
checked, failures = 0, []
for c in json.load(open(folder + "/charts.json"))["charts"]:
    if c["kind"] not in ("section", "network", "grains", "surfaces"):
        continue
    rgb = mi.imread(folder + "/" + c["file"])[..., :3]
    h, w, _ = rgb.shape
    colours = len(np.unique((255 * rgb).astype(np.uint8).reshape(-1, 3), axis=0))
    coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 0.15
    ys, xs = np.nonzero(coloured)
    checked += 1
    if colours < 16 or coloured.mean() < 0.02:
        failures.append(f"{c['file']}: {colours} colours, {100 * coloured.mean():.1f} % in colour")
    elif ys.min() < 2 or xs.min() < 2 or ys.max() > h - 3 or xs.max() > w - 3:
        failures.append(f"{c['file']}: the sample reaches the picture's edge")
    elif not (0.2 * w < xs.mean() < 0.8 * w and 0.2 * h < ys.mean() < 0.8 * h):
        failures.append(f"{c['file']}: the sample lies off the middle ({xs.mean():.0f}, {ys.mean():.0f}) of {w} x {h}")
print("\n".join(failures))
print(checked, "pictures checked")
sys.exit(1 if failures else 0)
)";

}  // namespace

namespace {

/// The full run with `option` naming `file` in place of the run's own is refused (exit 1) with a
/// message that starts with the file's name followed by `words`, leaving nothing in `out`.
void expect_run_file_refused(const test::TempDir& out, const fs::path& file, const std::string& option, const std::string& words) {
  test::expect_clean_failure("report", out, {g_runs->full.string(), (out / "r.html").string(), option, file.string()}, 1,
                             file.string() + words);
}

}  // namespace

TEST(ReportCli, StandardCli) { test::expect_standard_cli("report"); }

TEST_F(Report, MicroAndForcesTablesOfUnequalLengthAreRefusedNamingTheFile) {
  test::TempDir out;
  fs::copy_file(g_runs->full / "micro.h5", out / "rdf.h5");
  test::replace_dataset(out / "rdf.h5", "/states/1/rdf/g", std::vector<double>{1.0, 2.0}, {2});
  expect_run_file_refused(out, out / "rdf.h5", "--micro", ": state 1's g(r) or PSD columns differ in length; rewrite it with tracks2micro");
  fs::copy_file(g_runs->full / "micro.h5", out / "clusters.h5");
  test::replace_dataset(out / "clusters.h5", "/increments/0/clusters/radius_of_gyration", std::vector<double>{}, {0});
  expect_run_file_refused(out, out / "clusters.h5", "--micro", ": /increments/0/clusters/size and /radius_of_gyration differ in length");
  fs::copy_file(g_runs->full / "forces.h5", out / "forces.h5");
  test::replace_dataset(out / "forces.h5", "/frames/0/rose/mean_force", std::vector<double>{1.0}, {1});
  expect_run_file_refused(out, out / "forces.h5", "--forces", ": /frames/0/rose/mean_force does not have one value per rose bin");
}

TEST_F(Report, TablesOfUnequalLengthOrValuesNoToolWritesAreRefusedNamingTheFile) {
  test::TempDir out;
  // A column the report does not draw still makes the table, and the file, damaged.
  fs::copy_file(g_runs->full / "tracks.h5", out / "tracks.h5");
  test::replace_dataset(out / "tracks.h5", "/tracks/confidence", std::vector<double>{0.5}, {1});
  expect_run_file_refused(out, out / "tracks.h5", "--tracks", ": the table /tracks has columns of different lengths");
  fs::copy_file(g_runs->full / "micro.h5", out / "d50.h5");
  std::vector<double> d50 = io::H5File::open(out / "d50.h5").read<double>("/increments/d50");
  d50.back() = std::numeric_limits<double>::infinity();
  test::replace_dataset(out / "d50.h5", "/increments/d50", d50, {d50.size()});
  expect_run_file_refused(out, out / "d50.h5", "--micro",
          ": /increments/d50 holds infinity in row " + std::to_string(d50.size() - 1) +
              ", a value no GrainTwin tool writes there; rewrite it with tracks2micro");
  fs::copy_file(g_runs->full / "simulation.h5", out / "simulation.h5");
  const std::string frame = "/frames/000001/grains/centroid";
  std::vector<hsize_t> dims;
  std::vector<double> centroid = io::H5File::open(out / "simulation.h5").read<double>(frame, &dims);
  centroid[4] = std::nan("");
  test::replace_dataset(out / "simulation.h5", frame, centroid, dims);
  expect_run_file_refused(out, out / "simulation.h5", "--simulation", ": " + frame + " holds NaN in row 1");
  // The report shows only the model's provenance, but it vouches for a model fdemrun would refuse.
  fdem::write_model_file(out / "model.h5", test::cube_sample(1e-3), {"a cube"});
  test::replace_dataset(out / "model.h5", "/materials/young", std::vector<double>{std::numeric_limits<double>::infinity()}, {1});
  expect_run_file_refused(out, out / "model.h5", "--model", "");
}

TEST_F(Report, FullRunNamesEveryPanelEmbedsEveryChartAndKeepsTheNumbers) {
  ASSERT_EQ(full_report().exit_code, 0) << full_report().err;
  const fs::path out = g_runs->page.parent_path();
  const std::string html = slurp(g_runs->page);
  for (const std::string& id : kPanels) EXPECT_NE(html.find("<section class=\"panel\" id=\"" + id + "\">"), std::string::npos) << id;
  EXPECT_NE(html.find("Accuracy against time per stage"), std::string::npos);
  EXPECT_NE(html.find("<details id=\"provenance\">"), std::string::npos);
  EXPECT_NE(html.find("phantom labels of scan 2"), std::string::npos) << "the files' histories belong in the provenance section";
  EXPECT_NE(html.find("validate of the phantom run"), std::string::npos) << "validation.json's history belongs there too";
  // The error budget: every line with its number and its chart.
  EXPECT_NE(html.find("<section id=\"budget\">"), std::string::npos);
  for (const std::string& id : kBudgetLines) EXPECT_NE(html.find("id=\"budget_" + id + "\""), std::string::npos) << id;
  EXPECT_NE(html.find("<span class=\"value\">97.4 %</span>"), std::string::npos) << "(62 + 63 + 62) of 192 true grains right";
  EXPECT_NE(html.find("<span class=\"value\">122 right, 2 wrong, 0 lost</span>"), std::string::npos);
  EXPECT_EQ(count_of(html, "class=\"budget\""), kBudgetLines.size());
  // Every side with data has its chart; CT has no forces or stresses, so exactly those four
  // experiment sides (stress ratio, force rose, force PDF, volatility) say so instead.
  const nlohmann::json spec = nlohmann::json::parse(slurp(out / "report_img/charts.json"));
  EXPECT_EQ(spec["charts"].size(),
            2 * kPanels.size() - 4 + 2 * kSectionPanels.size() - kSectionSidesMissing + 2 * kClusterPanels.size() - 1 +
                2 * kEpsQPanels.size() - 1 + kSurfacePictures + kNetworkPanels.size() + kBudgetLines.size());
  const auto* twin = find_chart(spec, "budget_twin.png");
  ASSERT_NE(twin, nullptr);
  ASSERT_NE(find_series(*twin, "twin"), nullptr);
  EXPECT_EQ((*find_series(*twin, "twin"))["y"][1].get<double>(), 2.2);
  std::string sides_missing;
  for (const std::string& id : kPanels) {
    const std::size_t at = html.find("id=\"" + id + "\""), end = html.find("</section>", at);
    const std::string section = html.substr(at, end - at);
    if (count_of(section, "<p class=\"missing\">") > 0) sides_missing += " " + id + ":" + std::to_string(count_of(section, "<p class=\"missing\">"));
  }
  EXPECT_EQ(sides_missing, " stress_ratio:1 rose_forces:1 force_pdf:1 volatility:1");
  const auto bench = report::find_bench_charts(fs::path(GRAINTWIN_SOURCE_DIR) / "docs/img");
  EXPECT_EQ(count_of(html, "src=\"data:image/png;base64,"), spec["charts"].size() + bench.size());
  EXPECT_NE(html.find("data-images-total=\"" + std::to_string(spec["charts"].size() + bench.size()) + "\""), std::string::npos);
  for (const auto& c : spec["charts"]) {
    const std::string png = slurp(out / "report_img" / c["file"].get<std::string>());
    ASSERT_GT(png.size(), 1000u) << c["file"];
    EXPECT_EQ(png.substr(1, 3), "PNG") << c["file"];
  }
  EXPECT_EQ(fs::exists(out / "report_img/bench"), !bench.empty());

  // The experiment's strains: the applied axial strains as given, the tracked ones from the
  // centroids' affine map, close to the applied map (the balls' nudges are not affine).
  const auto* vol = find_chart(spec, "volumetric_strain_experiment.png");
  ASSERT_NE(vol, nullptr);
  const auto* applied = find_series(*vol, "scans, void ratio at the applied axial strain");
  const auto* tracked = find_series(*vol, "scans, affine map of the tracked centroids");
  ASSERT_NE(applied, nullptr);
  ASSERT_NE(tracked, nullptr);
  for (int t = 0; t < kScans; ++t) {
    EXPECT_NEAR((*applied)["x"][t].get<double>(), 100.0 * applied_axial_strain(t), 1e-9);
    EXPECT_NEAR((*tracked)["x"][t].get<double>(), 100.0 * applied_axial_strain(t), 0.1) << "scan " << t;
    const double volumetric = -std::log((1.0 - kAxialStep * t) * std::pow(1.0 + kLateralStep * t, 2));
    EXPECT_NEAR((*tracked)["y"][t].get<double>(), 100.0 * volumetric, 0.1) << "scan " << t;
  }
  // The simulation's series exactly as stored, the scans marked at their applied strains.
  const auto* ratio = find_chart(spec, "stress_ratio_simulation.png");
  ASSERT_NE(ratio, nullptr);
  const auto* curve = find_series(*ratio, "simulation");
  ASSERT_NE(curve, nullptr);
  const auto axial = sim_axial();
  ASSERT_EQ((*curve)["y"].size(), kRows);
  for (std::size_t k = 0; k < kRows; k += 7) {
    EXPECT_NEAR((*curve)["x"][k].get<double>(), 100.0 * axial[k], 1e-12);
    EXPECT_NEAR((*curve)["y"][k].get<double>(), sim_ratio(axial[k]), 1e-12);
  }
  const auto* marks = find_series(*ratio, "scans (applied axial strain)");
  ASSERT_NE(marks, nullptr);
  EXPECT_EQ((*marks)["x"].size(), std::size_t(kScans));
  // The volatility scatter holds every grain with a defined D2min and volatility.
  const auto* vola = find_chart(spec, "volatility_simulation.png");
  ASSERT_NE(vola, nullptr);
  EXPECT_GT((*vola)["series"][0]["x"].size(), 10u);
}

TEST_F(Report, RunWithoutSimulationSaysSoInEveryPanel) {
  test::TempDir out;
  const auto r = run_tool("report", {g_runs->experiment.string(), (out / "page.html").string(), "--bench-img", out.path().string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = slurp(out / "page.html");
  for (const std::string& id : kPanels) EXPECT_NE(html.find("id=\"" + id + "\""), std::string::npos) << id;
  // Every simulation side is missing and says which stage makes it; the experiment keeps its 11,
  // and its pictures: the sections of three scans, D2min and eps_q of two increments, and the D2min
  // clusters and eps_q of two increments in 3D. Without a model the grains' surfaces say so.
  const std::size_t pictures = kScans + 2 * (kScans - 1) + 2 * (kScans - 1);
  EXPECT_EQ(count_of(html, "This run has no simulation results (simulation.h5, kind=fdem_results)"), kPanels.size() + pictures + 2)
      << "and the force-chain network's and the grains' surfaces' one panel each";
  EXPECT_EQ(count_of(html, "This run has no FDEM model (model.h5): the mesh stage (shapes2mesh) makes"), 1u);
  EXPECT_EQ(count_of(html, "src=\"data:image/png;base64,"), kPanels.size() - 4 + pictures);
  EXPECT_NE(html.find("No benchmark charts were found"), std::string::npos);
  // No validation.json: the error budget is one sentence.
  EXPECT_NE(html.find(report::kNoValidation), std::string::npos);
  EXPECT_EQ(count_of(html, "class=\"budget\""), 0u);
  EXPECT_FALSE(fs::exists(out / "page_img/bench"));
}

TEST_F(Report, FilesOfAnotherRunAreRefusedNamingThem) {
  test::TempDir out;
  fdem::write_model_file(out / "model.h5", test::cube_sample(1e-3), {"a cube"});
  test::expect_clean_failure("report", out, {g_runs->full.string(), (out / "r.html").string(), "--model", (out / "model.h5").string()}, 1,
                             (g_runs->full / "simulation.h5").string() + " holds 64 grains but the model " + (out / "model.h5").string());
  // The simulation's micro-mechanics (four frames) in place of the three scans'.
  const fs::path frames = g_runs->full / "simulation_micro.h5";
  test::expect_clean_failure("report", out, {g_runs->full.string(), (out / "r.html").string(), "--micro", frames.string()}, 2,
                             frames.string() + " follows 4 scans but the run has 3; rerun the micro stage");
}

TEST_F(Report, PicturesShowTheSampleBesideTheTwin) {
  ASSERT_EQ(full_report().exit_code, 0) << full_report().err;
  const fs::path img = g_runs->page.parent_path() / "report_img";
  const std::string html = slurp(g_runs->page);
  // The sample itself comes first, before the statistics.
  for (const std::string& id : kSectionPanels) {
    const std::size_t at = html.find("<section class=\"panel\" id=\"" + id + "\">");
    ASSERT_NE(at, std::string::npos) << id;
    EXPECT_LT(at, html.find("id=\"stress_ratio\"")) << id;
  }
  const nlohmann::json spec = nlohmann::json::parse(slurp(img / "charts.json"));
  // Scan 1: its label image over its grey values, horizontal and vertical through the axis, its
  // grains in the colours of their tracked identities in scan 0.
  const auto* scan = find_chart(spec, "section_scan_001_experiment.png");
  ASSERT_NE(scan, nullptr);
  ASSERT_EQ((*scan)["sections"].size(), 2u);
  EXPECT_EQ((*scan)["title"], "scan_001, axial strain 2.0 %") << "the applied strain, -ln 0.98";
  const auto& horizontal = (*scan)["sections"][0];
  const auto& vertical = (*scan)["sections"][1];
  EXPECT_EQ(horizontal["plane"], "xy");
  EXPECT_EQ(vertical["plane"], "xz");
  EXPECT_EQ(vertical["labels_file"], (g_runs->full / "scan_001/labels.h5").string());
  EXPECT_EQ(vertical["volume_file"], g_runs->volumes[1]);
  EXPECT_NEAR(vertical["index"].get<double>(), 26.5, 0.5) << "the middle of the 54 voxels (the phantom has no cylinder)";
  EXPECT_GT(vertical["identity"].size(), 50u);
  // The twin at frame 1 cut by the same planes: the vertical one through the lattice's third row
  // of cubes (4 x 4 squares), the horizontal one through a layer of 16; every outline in the frame
  // both sides share.
  const auto* twin = find_chart(spec, "section_scan_001_simulation.png");
  ASSERT_NE(twin, nullptr);
  ASSERT_EQ((*twin)["sections"].size(), 2u);
  for (int v = 0; v < 2; ++v) {
    const auto& view = (*twin)["sections"][v];
    EXPECT_EQ(view["outline"].size(), 16u) << view["plane"];
    EXPECT_EQ(view["extent"], (*scan)["sections"][v]["extent"]);
    const auto extent = view["extent"].get<std::array<double, 4>>();
    for (const auto& loop : view["outline"])
      for (std::size_t i = 0; i + 1 < loop.size(); i += 2) {
        EXPECT_GE(loop[i].get<double>(), extent[0]);
        EXPECT_LE(loop[i].get<double>(), extent[1]);
        EXPECT_GE(loop[i + 1].get<double>(), extent[2]);
        EXPECT_LE(loop[i + 1].get<double>(), extent[3]);
      }
  }
  // D2min of increment 1 painted on scan 1's grains with micro.h5's values, on one scale with the
  // simulation's and every other increment's.
  const micro::MicroTables m = micro::read_micro_tables(g_runs->full / "micro.h5");
  const auto* d2 = find_chart(spec, "section_d2min_1_experiment.png");
  ASSERT_NE(d2, nullptr);
  const auto& painted = (*d2)["sections"][0];
  std::map<std::uint32_t, nlohmann::json> value_of;
  for (std::size_t i = 0; i < painted["value_label"].size(); ++i) value_of[painted["value_label"][i]] = painted["value"][i];
  const std::size_t states = m.states.size(), increments = m.increments.size();
  std::size_t compared = 0;
  for (std::size_t n = 0; n < m.grains; ++n) {
    const std::uint32_t label = m.grain_label[n * states + 1];
    if (label == 0) continue;
    ASSERT_TRUE(value_of.count(label)) << label;
    const double d2min = m.grain_d2min[n * increments + 1];
    if (!std::isfinite(d2min)) {
      EXPECT_TRUE(value_of[label].is_null()) << label;
      continue;
    }
    EXPECT_EQ(value_of[label].get<double>(), d2min) << label;
    ++compared;
  }
  EXPECT_GT(compared, 40u);
  std::set<std::pair<double, double>> scales;
  for (const auto& c : spec["charts"])
    if (c["file"].get<std::string>().rfind("section_d2min_", 0) == 0)
      scales.insert({c["sections"][0]["colour_min"].get<double>(), c["sections"][0]["colour_max"].get<double>()});
  ASSERT_EQ(scales.size(), 1u) << "one colour scale for D2min";
  EXPECT_LT(scales.begin()->first, scales.begin()->second);
  // The force-chain network of frame 1: of the 96 chosen contacts (all pushing), those with at
  // least their mean normal force, from centroid to centroid, on one scale with the other frames'.
  const fdem::ResultsFrame frame = fdem::read_results_frame(g_runs->full / "simulation.h5", 1);
  std::vector<double> normal_force;
  for (std::size_t i = 0; i < frame.platen.size(); ++i)
    normal_force.push_back(Eigen::Vector3d(&frame.force[3 * i]).dot(Eigen::Vector3d(&frame.normal[3 * i])));
  ASSERT_EQ(normal_force.size(), 96u);
  const double mean = std::accumulate(normal_force.begin(), normal_force.end(), 0.0) / 96.0;
  const auto strong = std::count_if(normal_force.begin(), normal_force.end(), [&](double f) { return f >= mean; });
  const auto* network = find_chart(spec, "force_network_1_simulation.png");
  ASSERT_NE(network, nullptr);
  EXPECT_EQ((*network)["network"]["force"].size(), std::size_t(strong));
  EXPECT_EQ((*network)["network"]["segments"].size(), 6 * std::size_t(strong));
  for (const auto& f : (*network)["network"]["force"]) EXPECT_GE(f.get<double>(), mean);
  std::set<double> tops;
  for (const std::string& id : kNetworkPanels) {
    EXPECT_NE(html.find("<section class=\"panel\" id=\"" + id + "\">"), std::string::npos) << id;
    const auto* c = find_chart(spec, id + "_simulation.png");
    ASSERT_NE(c, nullptr) << id;
    tops.insert((*c)["network"]["force_max"].get<double>());
  }
  EXPECT_EQ(tops.size(), 1u) << "one force scale for every frame";
  // D2min in 3D, increment 0: every tracked grain of scan 0 at its tracked centroid, painted with
  // micro.h5's D2min, the clusters' members highlighted; one colour scale and one camera for all.
  const track::TrackedCentroids tracked = track::read_tracked_centroids(g_runs->full / "tracks.h5");
  const auto* clusters = find_chart(spec, "clusters_3d_0_experiment.png");
  ASSERT_NE(clusters, nullptr);
  const auto& grains = (*clusters)["grains"];
  std::size_t row = 0, members = 0;
  for (std::size_t n = 0; n < m.grains; ++n) {
    if (m.grain_label[n * states] == 0) continue;
    for (int a = 0; a < 3; ++a) EXPECT_EQ(grains["centre"][3 * row + a].get<double>(), tracked.centroid[3 * n * tracked.scans + a]);
    const double d2min = m.grain_d2min[n * increments];
    if (std::isfinite(d2min)) EXPECT_EQ(grains["value"][row].get<double>(), d2min);
    EXPECT_EQ(grains["highlighted"][row].get<int>(), m.grain_cluster[n * increments] >= 0 ? 1 : 0);
    members += m.grain_cluster[n * increments] >= 0;
    ++row;
  }
  EXPECT_EQ(grains["centre"].size(), 3 * row);
  EXPECT_GT(members, 0u) << "tracks2micro's top fraction makes clusters";
  // The camera boxes and colour scales of the 3D grain pictures of `panels`, both sides.
  const auto cameras_and_scales = [&](const std::vector<std::string>& panels) {
    std::set<std::string> seen;
    for (const std::string& id : panels)
      for (const char* side : {"_experiment.png", "_simulation.png"})
        if (const auto* c = find_chart(spec, id + side))
          seen.insert((*c)["grains"]["bounds"].dump() + (*c)["grains"]["colour_min"].dump() + (*c)["grains"]["colour_max"].dump());
    return seen;
  };
  EXPECT_EQ(cameras_and_scales(kClusterPanels).size(), 1u) << "one camera and one colour scale for every 3D picture of D2min";
  // eps_q in 3D, increment 0: every tracked grain of scan 0 outside the front quarter, painted with
  // micro.h5's eps_q; no grain left in that quarter; one camera and colour scale for all.
  const auto* eps_q = find_chart(spec, "eps_q_3d_0_experiment.png");
  ASSERT_NE(eps_q, nullptr);
  const auto& painted_3d = (*eps_q)["grains"];
  const auto bounds = painted_3d["bounds"].get<std::array<double, 6>>();
  const double cut_x = 0.5 * (bounds[0] + bounds[1]), cut_y = 0.5 * (bounds[2] + bounds[3]);
  std::map<std::array<double, 3>, nlohmann::json> eps_q_at;
  for (std::size_t i = 0; i < painted_3d["radius"].size(); ++i) {
    const std::array<double, 3> c{painted_3d["centre"][3 * i].get<double>(), painted_3d["centre"][3 * i + 1].get<double>(),
                                  painted_3d["centre"][3 * i + 2].get<double>()};
    EXPECT_FALSE(c[0] > cut_x && c[1] < cut_y) << "a grain in the front quarter cut away";
    EXPECT_EQ(painted_3d["highlighted"][i].get<int>(), 1) << "every grain is painted";
    eps_q_at[c] = painted_3d["value"][i];
  }
  std::size_t kept = 0, in_cut = 0;
  for (std::size_t n = 0; n < m.grains; ++n) {
    if (m.grain_label[n * states] == 0) continue;
    const double* c = &tracked.centroid[3 * n * tracked.scans];
    if (c[0] > cut_x && c[1] < cut_y) {
      ++in_cut;
      continue;
    }
    const std::array<double, 3> at{c[0], c[1], c[2]};
    ASSERT_TRUE(eps_q_at.count(at)) << "grain " << n;
    const double value = m.grain_eps_q[n * increments];
    if (std::isfinite(value)) EXPECT_EQ(eps_q_at[at].get<double>(), value);
    ++kept;
  }
  EXPECT_EQ(eps_q_at.size(), kept);
  EXPECT_GT(in_cut, 5u) << "about a quarter of the 64 grains";
  EXPECT_EQ(cameras_and_scales(kEpsQPanels).size(), 1u) << "one camera and one colour scale for every 3D picture of eps_q";
  // The grains' surfaces: the 48 cubes outside the front quarter of the lattice (sites 0 to 4.5 mm,
  // cut at its middle, 2.25 mm) whole, scan 0's and the twin's at its last frame with the membrane
  // balls outside the cut; the triangles' files are gone once drawn.
  for (const char* side : {"grains_3d_experiment.png", "grains_3d_simulation.png"}) {
    const auto* c = find_chart(spec, side);
    ASSERT_NE(c, nullptr) << side;
    const auto& v = (*c)["surfaces"];
    EXPECT_EQ(v["grains"], 48) << side;
    EXPECT_EQ(v["grains_cut"], 16) << side;
    EXPECT_EQ(v["triangles"], v["source_triangles"]) << side << ": cubes need no simplification";
    EXPECT_NEAR(v["cut"][0].get<double>(), 2.25e-3, 1e-12);
    EXPECT_FALSE(fs::exists(img / v["mesh_file"].get<std::string>())) << side;
  }
  const auto& membrane = (*find_chart(spec, "grains_3d_simulation.png"))["surfaces"]["membrane"];
  EXPECT_GT(membrane.size(), 3 * 100u);
  EXPECT_LT(membrane.size(), 3 * 192u) << "the balls in the front quarter are cut away";
  EXPECT_NE(html.find("<section class=\"panel\" id=\"grains_3d\">"), std::string::npos);
  // Every picture shows something, with the sample inside the frame.
  const auto pixels = test::run_program("/usr/bin/python3", {"-c", kPixelCheck, img.string()});
  EXPECT_EQ(pixels.exit_code, 0) << pixels.out << pixels.err;
  const std::size_t pictures = 2 * kSectionPanels.size() - kSectionSidesMissing + 2 * kClusterPanels.size() - 1 +
                               2 * kEpsQPanels.size() - 1 + kSurfacePictures + kNetworkPanels.size();
  EXPECT_NE(pixels.out.find(std::to_string(pictures) + " pictures checked"), std::string::npos) << pixels.out;
}

TEST_F(Report, HeadlessChromiumLoadsEveryImage) {
  const fs::path chromium = "/usr/bin/chromium";
  if (!fs::exists(chromium)) GTEST_SKIP() << "Debian's chromium is not installed (scripts/deps.sh installs it); the page was not rendered";
  ASSERT_EQ(full_report().exit_code, 0) << full_report().err;
  test::TempDir profile;
  const auto dom = test::run_program(chromium, {"--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                                                "--user-data-dir=" + profile.path().string(), "--virtual-time-budget=10000",
                                                "--dump-dom", "file://" + g_runs->page.string()});
  ASSERT_EQ(dom.exit_code, 0) << dom.err;
  std::smatch total, loaded;
  ASSERT_TRUE(std::regex_search(dom.out, total, std::regex("data-images-total=\"([0-9]+)\""))) << dom.out.substr(0, 500);
  ASSERT_TRUE(std::regex_search(dom.out, loaded, std::regex("data-images-loaded=\"([0-9a-z]+)\""))) << dom.out.substr(0, 500);
  EXPECT_GT(std::stoi(total[1]), 20);
  EXPECT_EQ(loaded[1].str(), total[1].str()) << "images that did not decode in Chromium";
}

/// Loads a state with the run folder as its data directory and prints each source's name and points
/// (every time step of a series counted), one per line.
constexpr const char* kLoadState = R"(
import sys
from paraview.simple import GetSources, LoadState
LoadState(sys.argv[1], data_directory=sys.argv[2])
for (name, _), source in sorted(GetSources().items()):
    times = list(getattr(source, "TimestepValues", None) or [None])
    points = []
    for t in times:
        source.UpdatePipeline(t) if t is not None else source.UpdatePipeline()
        points.append(source.GetDataInformation().GetNumberOfPoints())
    print(f"{name}: {min(points)} points in every one of {len(times)} steps")
)";

TEST_F(Report, ParaviewStateOpensEveryVtkFileOfTheRunFromWhereverTheRunFolderIsMoved) {
  test::TempDir dir;
  const fs::path run = dir / "run", moved = dir / "moved";
  fs::copy(g_runs->full, run, fs::copy_options::recursive);
  const auto r = run_tool("report", {run.string(), (run / "report.html").string(), "--paraview-state", (run / "twin.pvsm").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string state = slurp(run / "twin.pvsm");
  // Every VTK file of the run's stages, by its path relative to the state's folder.
  for (const char* file : {"scan_000/grains.vtp", "scan_001/grains.vtp", "scan_002/grains.vtp", "tracks.vtp",
                           "simulation_frames/frames.pvd", "twin_membrane/membrane.pvd", "force_chains/chains.pvd"})
    EXPECT_NE(state.find("value=\"" + std::string(file) + "\""), std::string::npos) << file;
  EXPECT_EQ(state.find(run.string()), std::string::npos) << "no absolute path";
  for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(fs::exists(run / fmt::format("twin_membrane/membrane_{}.vtp", k))) << k;
  fs::rename(run, moved);
  const fs::path pvpython = "/usr/bin/pvpython";
  if (!fs::exists(pvpython))
    GTEST_SKIP() << "ParaView's pvpython is not installed (Debian's paraview, left out of scripts/deps.sh to keep CI fast): "
                    "the state was written and checked, not loaded";
  const auto loaded = test::run_program(pvpython, {"-c", kLoadState, (moved / "twin.pvsm").string(), moved.string()});
  ASSERT_EQ(loaded.exit_code, 0) << loaded.out << loaded.err;
  for (const char* line : {"force chains: ", "grain tracks: ", "membrane balls: ", "scan_000 grains: ", "scan_001 grains: ", "scan_002 grains: ",
                           "twin frames: "}) {
    const std::size_t at = loaded.out.find(line);
    ASSERT_NE(at, std::string::npos) << line << " is not in the state:\n" << loaded.out;
    EXPECT_NE(loaded.out.substr(at + std::string(line).size(), 2), "0 ") << line << "has no points:\n" << loaded.out;
  }
  EXPECT_NE(loaded.out.find("twin frames: 512 points in every one of 4 steps"), std::string::npos)
      << "64 cubes of 8 nodes, 4 frames:\n" << loaded.out;
}

TEST(ReportFailures, BadInputsFailCleanly) {
  test::TempDir run, out;
  fs::create_directories(run / "scan_000");
  write_labels(run / "scan_000/labels.h5", 0);
  const std::string labels = (run / "scan_000/labels.h5").string(), page = (out / "r.html").string();
  test::expect_clean_failure("report", out, {(out / "no_such_run").string(), page}, 2, "no_such_run does not exist; run the pipeline");
  test::expect_clean_failure("report", out, {out.path().string(), page}, 2, "holds no scan_*/labels.h5; run the segment stage");
  test::expect_clean_failure("report", out, {run.path().string(), (out / "r.txt").string()}, 2, "must end in .html");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--paraview-state", (out / "twin.xml").string()}, 2,
                             "--paraview-state " + (out / "twin.xml").string() + " must end in .pvsm");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--tracks", labels}, 2, "pass the output of shapes2tracks");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--shapes", labels, labels}, 2, "give one per scan");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--scan-strains", labels}, 2, "pass a series.json");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--micro", (run / "none.h5").string()}, 2, "none.h5 does not exist");
  // The scans under the labels: of kind volume, one per scan, of the labels' geometry.
  test::expect_clean_failure("report", out, {run.path().string(), page, "--volumes", labels}, 2,
                             "pass the scan the labels were segmented from");
  io::write_volume_file(run / "small.h5", AnyVolume(Volume<std::uint8_t>({10, 10, 10})), {"a small scan"});
  test::expect_clean_failure("report", out, {run.path().string(), page, "--volumes", (run / "small.h5").string()}, 2,
                             "--volumes " + (run / "small.h5").string() + " is not the scan of " + labels);
  test::expect_clean_failure("report", out, {run.path().string(), page, "--volumes", labels, labels}, 2, "give one per scan");
  const fs::path broken = run / "broken.py";
  std::ofstream(broken) << "import sys\nsys.exit('matplotlib is missing here')\n";
  test::expect_clean_failure("report", out, {run.path().string(), page, "--chart-script", broken.string()}, 1, "matplotlib is missing here");
  // A run of one labelled scan and nothing else is a page that says what each stage would add.
  ASSERT_EQ(run_tool("report", {run.path().string(), page}).exit_code, 0);
  test::expect_clean_failure("report", out, {run.path().string(), page}, 2, "--force");
}

TEST(ReportFailures, PathsOfTheWrongKindSayWhatTheyAreAndWhatIsExpected) {
  test::TempDir run, out;
  fs::create_directories(run / "scan_000");
  write_labels(run / "scan_000/labels.h5", 0);
  const std::string labels = (run / "scan_000/labels.h5").string(), page = (out / "r.html").string();
  // A file where the run folder belongs.
  test::expect_clean_failure("report", out, {labels, page}, 2,
                             "the run directory " + labels + " is a file, not a folder; pass the folder Makefile.pipeline");
  // Folders where files belong: an option's, and one with a layout name inside the run.
  test::expect_clean_failure("report", out, {run.path().string(), page, "--labels", (run / "scan_000").string()}, 2,
                             "--labels " + (run / "scan_000").string() + " is a folder, not a file; name the file itself");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--python", run.path().string()}, 2,
                             "--python " + run.path().string() + " is a folder, not a file");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--chart-script", run.path().string()}, 2,
                             "--chart-script " + run.path().string() + " is a folder, not a file");
  test::expect_clean_failure("report", out, {run.path().string(), page, "--bench-img", labels}, 2,
                             "--bench-img " + labels + " is a file, not a folder; pass the repository's docs/img");
  fs::create_directories(run / "tracks.h5");
  test::expect_clean_failure("report", out, {run.path().string(), page}, 2,
                             "the run's file " + (run / "tracks.h5").string() + " is a folder, not a file; move it out of "
                             "the run directory, or name the file with --tracks");
  fs::remove(run / "tracks.h5");
  fs::create_directories(run / "scan_000/contacts.h5");
  test::expect_clean_failure("report", out, {run.path().string(), page}, 2,
                             (run / "scan_000/contacts.h5").string() + " is a folder, not a file");
}

TEST(ReportFailures, ChartScriptDiesWithAKilledReport) {
  test::TempDir run, out;
  fs::create_directories(run / "scan_000");
  write_labels(run / "scan_000/labels.h5", 0);
  const fs::path script = run / "slow.py";
  std::ofstream(script) << "import time\ntime.sleep(60)\n";
  const pid_t report = test::spawn_tool("report", {run.path().string(), (out / "r.html").string(), "--chart-script", script.string(), "-q"});
  std::vector<pid_t> children;
  for (int tries = 0; tries < 3000 && children.empty(); ++tries) {  // up to 30 s: the run is read first
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    children = test::child_pids(report);
  }
  ASSERT_EQ(children.size(), 1u) << "the chart script did not start";
  ASSERT_EQ(::kill(report, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(report, &status, 0), report);
  EXPECT_TRUE(test::process_ends_within(children[0], std::chrono::seconds(1))) << "the chart script outlived the report";
  ::kill(children[0], SIGKILL);  // not left behind when it did
}

TEST(ReportFailures, OptionsOutsideTheirRangeAreRefused) {
  test::TempDir out;
  test::expect_clean_failure("report", out, {out.path().string(), (out / "r.html").string(), "--max-series", "nan"}, 2,
                             "--max-series: must be a whole number in [1, 20], not nan");
}
