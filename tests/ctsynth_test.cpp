// ctsynth: CLI contract, a small complete series with consistent ground truth, determinism, and
// scenes that cannot be made.
#include <Eigen/Core>
#include <gtest/gtest.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <numbers>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using test::run_tool;
namespace fs = std::filesystem;

namespace {
// About 60 small grains in a 1.4 mm cylinder at 40 um voxels: a complete series in a few seconds.
void write_scene(const fs::path& p, const std::string& extra = "") {
  std::ofstream(p) << "seed = 5\ngrain-shape = \"sand\"\nsh-degree = 10\n"
                      "d-min = \"0.25mm\"\nd50 = \"0.35mm\"\nd-max = \"0.45mm\"\n"
                      "diameter = \"1.4mm\"\nheight = \"1.6mm\"\nsolid-fraction = 0.45\ncontact-tolerance = 0.02\n"
                      "voxel-size = \"35um\"\nstrains = [0.0, 0.03]\nband-width = \"0.7mm\"\n"
                   << extra;
}

// Every grain appears in the truth's label image, and its voxel count (35 um voxels) matches its
// true volume within 15 % (the voxel counts of 8-12 voxel grains).
void expect_label_counts_match_volumes(const io::H5File& truth, std::size_t grains) {
  const auto labels = io::read_image_as<std::uint32_t>(truth, "/labels");
  std::vector<double> count(grains + 1, 0.0);
  for (auto l : labels.values()) count[l] += 1.0;
  const auto volume = truth.read<double>("/grains/volume");
  const double vv = std::pow(35e-6, 3);
  for (std::size_t i = 0; i < grains; ++i) EXPECT_NEAR(count[i + 1] * vv / volume[i], 1.0, 0.15) << "grain " << i + 1;
}
}  // namespace

TEST(Ctsynth, StandardCli) { test::expect_standard_cli("ctsynth", "scene"); }

TEST(Ctsynth, DeepKinematicsAreReachedInRelaxedSteps) {
  // Random grain motion of 6 band slips pushes grains into each other by more than a third of d50,
  // which one relaxation does not undo at paper size: the state is reached from the one before in
  // relaxed steps, and ends within the tolerance like any other.
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), (dir / "out").string(), "--nonaffine", "6"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("relaxed steps"), std::string::npos) << r.err;
  const auto series = nlohmann::json::parse(std::ifstream(dir / "out" / "series.json"));
  const io::H5File truth = io::open_kind(dir / "out" / "truth_001.h5", "ground_truth");
  const double tolerance = *truth.attr_doubles("/", "contact_tolerance").begin();
  EXPECT_GT(tolerance, 0.0);
  EXPECT_LE(series["scans"][1]["max_overlap_m"].get<double>(), tolerance);
}

TEST(Ctsynth, MakesAConsistentSeries) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), (dir / "out").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(test::list_dir(dir / "out"),
            (std::vector<std::string>{".graintwin-output", "scan_000.h5", "scan_001.h5", "scene.toml", "series.json", "truth_000.h5",
                                      "truth_001.h5"}));
  const auto series = nlohmann::json::parse(std::ifstream(dir / "out" / "series.json"));
  const std::size_t n = series["grains"];
  EXPECT_GT(n, 30u);
  for (int k = 0; k < 2; ++k) {
    const std::string idx = k == 0 ? "000" : "001";
    const io::H5File scan = io::open_kind(dir / "out" / ("scan_" + idx + ".h5"), "volume");
    const io::H5File truth = io::open_kind(dir / "out" / ("truth_" + idx + ".h5"), "ground_truth");
    const io::ImageHeader hs = io::read_image_header(scan, "/volume");
    EXPECT_EQ(hs.dtype, DType::uint16);
    EXPECT_EQ(io::read_image_header(truth, "/labels").shape, hs.shape);
    EXPECT_EQ(truth.read<std::uint32_t>("/grains/label").size(), n);
    EXPECT_NEAR(*truth.attr_doubles("/", "axial_strain").begin(), k == 0 ? 0.0 : 0.03, 1e-12);
    expect_label_counts_match_volumes(truth, n);
    // Contacts: low < high, unit normals pointing from low to high, touching ones within tolerance.
    std::vector<hsize_t> dims;
    const auto pair = truth.read<std::uint32_t>("/contacts/pair", &dims);
    const auto normal = truth.read<double>("/contacts/normal");
    const auto centroid = truth.read<double>("/grains/centroid");
    const auto touching = truth.read<std::uint8_t>("/contacts/touching");
    ASSERT_GT(dims[0], n);  // dense packing: more contacts than grains
    std::size_t touch = 0;
    for (std::size_t c = 0; c < dims[0]; ++c) {
      const auto a = pair[2 * c] - 1, b = pair[2 * c + 1] - 1;
      ASSERT_LT(a, b);
      Eigen::Vector3d nrm(normal[3 * c], normal[3 * c + 1], normal[3 * c + 2]);
      EXPECT_NEAR(nrm.norm(), 1.0, 1e-9);
      const Eigen::Vector3d branch(centroid[3 * b] - centroid[3 * a], centroid[3 * b + 1] - centroid[3 * a + 1],
                                   centroid[3 * b + 2] - centroid[3 * a + 2]);
      EXPECT_GT(nrm.dot(branch), 0.0);
      touch += touching[c];
    }
    EXPECT_GT(2.0 * touch / n, 2.0) << "grains of a relaxed packing touch their neighbours";
    EXPECT_EQ(io::read_history(scan).size(), 1u);
  }
}

TEST(Ctsynth, SameSeedSameBytesOtherSeedOtherBytes) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const std::vector<std::string> common{(dir / "scene.toml").string(), "--strains", "0", "-q"};
  auto args = common;
  args.push_back((dir / "a").string());
  ASSERT_EQ(run_tool("ctsynth", args).exit_code, 0);
  args = common;
  args.insert(args.end(), {(dir / "b").string(), "-j", "1"});
  ASSERT_EQ(run_tool("ctsynth", args).exit_code, 0);
  args = common;
  args.insert(args.end(), {(dir / "c").string(), "--seed", "6"});
  ASSERT_EQ(run_tool("ctsynth", args).exit_code, 0);
  auto vol = [&](const char* run) {
    return io::read_image_as<std::uint16_t>(io::H5File::open(dir / run / "scan_000.h5"), "/volume").values();
  };
  EXPECT_EQ(vol("a"), vol("b")) << "the bytes must not depend on the thread count";
  EXPECT_NE(vol("a"), vol("c"));
  // The series' own scene.toml, the effective options, gives the same series again.
  const auto again = run_tool("ctsynth", {(dir / "a" / "scene.toml").string(), (dir / "d").string(), "-q"});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(vol("a"), vol("d"));
}

// The other grain shapes: spheres come out as spheres and ellipsoids with the asked aspect ratio,
// packed and rendered like sand (label voxels near each grain's exact volume).
TEST(Ctsynth, SphereAndEllipsoidScenes) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  for (const auto& [shape, aspect] : std::vector<std::pair<std::string, double>>{{"sphere", 1.0}, {"ellipsoid", 1.4}}) {
    const fs::path out = dir / shape;
    const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), out.string(), "--strains", "0", "--grain-shape",
                                        shape, "--aspect-ratio", std::to_string(aspect), "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const io::H5File truth = io::H5File::open(out / "truth_000.h5");
    const auto ar = truth.read<double>("/grains/aspect_ratio");
    const auto sph = truth.read<double>("/grains/sphericity");
    ASSERT_GT(ar.size(), 30u) << shape;
    for (std::size_t i = 0; i < ar.size(); ++i) {
      EXPECT_NEAR(ar[i], aspect, 0.01 * aspect) << shape << " grain " << i;
      if (shape == "sphere") {
        EXPECT_NEAR(sph[i], 1.0, 1e-3) << "grain " << i;
      }
    }
    expect_label_counts_match_volumes(truth, ar.size());
  }
}

// Angular grains (sharp-edged polyhedra with dents and roughness) are packed and rendered: the scan
// and truth are written, the truth holds every grain of the series, each grain's voxels match its
// exact volume, and the grains are clearly less spherical than smooth sand.
// Angular grains, a stated share of them with a pocket: none is round, the truth says what a radial
// description misses of each (nothing for the others), and the scans' label counts match the grains'
// true volumes.
TEST(Ctsynth, AngularSceneWithAShareOfNonStarGrains) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const fs::path out = dir / "pocketed";
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), out.string(), "--strains", "0", "--grain-shape",
                                      "angular", "--non-star-share", "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("grains are not star-shaped about their centroid"), std::string::npos) << r.err;
  const io::H5File truth = io::open_kind(out / "truth_000.h5", "ground_truth");
  const auto multi = truth.read<double>("/grains/multi_exit_fraction");
  const auto hidden = truth.read<double>("/grains/hidden_void_fraction");
  const auto depth = truth.read<double>("/grains/reentry_depth");
  ASSERT_EQ(hidden.size(), multi.size());
  const auto sph = truth.read<double>("/grains/sphericity");
  ASSERT_GT(sph.size(), 30u);
  for (std::size_t i = 0; i < sph.size(); ++i) EXPECT_LT(sph[i], 0.95) << "grain " << i;
  std::size_t pocketed = 0;
  for (std::size_t i = 0; i < multi.size(); ++i) {
    if (multi[i] == 0.0) {
      EXPECT_EQ(hidden[i], 0.0);
      EXPECT_EQ(depth[i], 0.0);
      continue;
    }
    ++pocketed;
    EXPECT_GT(depth[i], 35e-6) << "grain " << i + 1;  // deeper than a voxel
  }
  EXPECT_EQ(pocketed, (multi.size() + 1) / 2);
  const nlohmann::json series = nlohmann::json::parse(std::ifstream(out / "series.json"));
  EXPECT_GE(series["non_star_grains"].get<std::size_t>(), pocketed / 2);
  expect_label_counts_match_volumes(truth, multi.size());
}

// A shape library from a segmented scan: two whole grains (one hollow, one a ball) and one cut by
// the field of view, which is left out. The series is made of copies of the two, at their size,
// and the truth measures the hollow one's cavity.
TEST(Ctsynth, LibraryGrainsFromASegmentedScan) {
  test::TempDir dir;
  const double voxel = 2e-5;
  segment::LabelsFile c;
  c.labels = test::label_hollow_grain_and_ball(80, {voxel, voxel, voxel});
  for (std::size_t z = 14; z < 27; ++z)  // label 3: a grain the field of view cuts
    for (std::size_t y = 14; y < 27; ++y)
      for (std::size_t x = 72; x < 80; ++x)
        if (std::hypot(z - 20.0, y - 20.0, x - 79.0) <= 6.0) c.labels(z, y, x) = 3;
  c.grains = segment::grain_table(c.labels);
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "labels.h5", c, {"phantom labels"});
  const auto measured = run_tool("labels2shapes", {(dir / "labels.h5").string(), (dir / "shapes.h5").string(), "-q"});
  ASSERT_EQ(measured.exit_code, 0) << measured.err;
  write_scene(dir / "scene.toml");
  const fs::path out = dir / "library";
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), out.string(), "--strains", "0", "--grain-shape",
                                      "library", "--library", (dir / "shapes.h5").string(), "--library-labels",
                                      (dir / "labels.h5").string(), "--container", "box", "--box", "1.5mm,1.5mm,1.5mm",
                                      "--solid-fraction", "0.35", "--voxel-size", "20um", "--band", "none"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("drawn from a library of 2 (1 left out)"), std::string::npos) << r.err;
  const io::H5File truth = io::open_kind(out / "truth_000.h5", "ground_truth");
  const auto volume = truth.read<double>("/grains/volume");
  const auto hidden = truth.read<double>("/grains/hidden_void_fraction");
  ASSERT_GE(volume.size(), 6u);
  const double v_hollow = (std::pow(15.0, 3) - std::pow(5.5, 3)) * 4.0 / 3.0 * std::numbers::pi * std::pow(voxel, 3);
  const double v_ball = std::pow(12.0, 3) * 4.0 / 3.0 * std::numbers::pi * std::pow(voxel, 3);
  const double cavity_share = std::pow(5.5, 3) / (std::pow(15.0, 3) - std::pow(5.5, 3));
  std::size_t hollow_grains = 0;
  for (std::size_t i = 0; i < volume.size(); ++i) {
    if (std::abs(volume[i] / v_hollow - 1.0) < 0.05) {
      ++hollow_grains;
      EXPECT_NEAR(hidden[i] / cavity_share, 1.0, 0.15) << "grain " << i + 1;
    } else {
      EXPECT_NEAR(volume[i] / v_ball, 1.0, 0.05) << "grain " << i + 1;
      EXPECT_EQ(hidden[i], 0.0) << "grain " << i + 1;
    }
  }
  EXPECT_GT(hollow_grains, 0u);
  EXPECT_LT(hollow_grains, volume.size());
  // The cavity is rendered: the truth labels hold each grain's voxels without it.
  const auto labels = io::read_image_as<std::uint32_t>(truth, "/labels");
  std::vector<double> count(volume.size() + 1, 0.0);
  for (auto l : labels.values()) count[l] += 1.0;
  for (std::size_t i = 0; i < volume.size(); ++i)
    EXPECT_NEAR(count[i + 1] * std::pow(voxel, 3) / volume[i], 1.0, 0.05) << "grain " << i + 1;
  // A library file is an input: never an output, even with --force; a file of another kind is refused.
  test::expect_clean_failure("ctsynth", dir,
                             {(dir / "scene.toml").string(), (dir / "shapes.h5").string(), "--force", "--grain-shape",
                              "library", "--library", (dir / "shapes.h5").string(), "--library-labels",
                              (dir / "labels.h5").string()},
                             2, "shapes.h5");
  test::expect_clean_failure("ctsynth", dir,
                             {(dir / "scene.toml").string(), (dir / "x").string(), "--grain-shape", "library", "--library",
                              (dir / "labels.h5").string(), "--library-labels", (dir / "labels.h5").string()},
                             2, "labels2shapes");
  // The labels the shapes were not measured from are refused, naming both files.
  for (auto& l : c.labels.values()) l = l == 1 ? 0 : l;
  c.grains = segment::grain_table(c.labels);
  segment::write_labels_file(dir / "other.h5", c, {"without grain 1"});
  test::expect_clean_failure("ctsynth", dir,
                             {(dir / "scene.toml").string(), (dir / "x").string(), "--grain-shape", "library",
                              "--library", (dir / "shapes.h5").string(), "--library-labels", (dir / "other.h5").string()},
                             2, "has no grain with label 1 of");
}

// The pipeline's triaxial scene with coarser membrane balls, so that the test runs in seconds.
fs::path write_loading_scene(const fs::path& dir) {
  std::ofstream(dir / "triaxial.toml") << "[run]\ndamping = 2000\nkeep_initial_overlaps = true\noverlap_tolerance = 0.3\n"
                                          "mass_scaled_share = 0.05\n[model]\nkind = \"rigid\"\n"
                                          "[triaxial]\nboundary = \"membrane\"\nconfining_pressure = 300e3\n"
                                          "ball_radius = 0.05e-3\nservo_inertial_number = 1e-2\nshear_inertial_number = 1e-2\n";
  return dir / "triaxial.toml";
}

TEST(Ctsynth, SimulatedLoadingRendersTheTriaxialTestsFramesWithTheirForces) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const fs::path out = dir / "out";
  // About 25 grains: the test's cost is the consolidation's few thousand steps.
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), out.string(), "-q", "--loading", "simulated",
                                      "--triaxial-scene", write_loading_scene(dir.path()).string(), "--strains", "0,0.01",
                                      "--simulated-surface-nodes", "100", "--diameter", "1.0mm", "--height", "1.2mm"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto series = nlohmann::json::parse(std::ifstream(out / "series.json"));
  EXPECT_EQ(series["loading"], "simulated");
  // The simulation's own results are kept, its frames at the scans' strains.
  const io::H5File sim = io::open_kind(out / "simulation.h5", "fdem_results");
  const io::H5File t0 = io::open_kind(out / "truth_000.h5", "ground_truth"), t1 = io::open_kind(out / "truth_001.h5", "ground_truth");
  const std::size_t n = t0.read<std::uint32_t>("/grains/label").size();
  const double eps1 = t1.attr_double("/", "axial_strain");
  EXPECT_EQ(t0.attr_double("/", "axial_strain"), 0.0);
  EXPECT_NEAR(eps1, 0.01, 5e-4);
  // The platens: H1 = H0 exp(-eps1), the log strain of the test (to the platens' travel in a step:
  // the series row is booked at the frame's step, the strain measured after it).
  EXPECT_NEAR(t1.attr_double("/", "sample_height"), t0.attr_double("/", "sample_height") * std::exp(-eps1), 1e-8);
  // Every grain moved as the simulation moved its body: the truth's displacement of each grain is
  // the frame's centroid displacement (the SH origin and the mesh centroid differ by micrometres,
  // so the turn between the scans moves them apart by far less than a voxel).
  const auto p0 = t0.read<double>("/grains/centroid"), p1 = t1.read<double>("/grains/centroid");
  std::vector<std::string> frames = sim.list("/frames");
  ASSERT_GE(frames.size(), 2u);
  const auto c0 = sim.read<double>("/frames/" + frames.front() + "/grains/centroid");
  const auto c1 = sim.read<double>("/frames/" + frames.back() + "/grains/centroid");
  ASSERT_EQ(c0.size(), 3 * n);
  double moved = 0.0;
  for (std::size_t i = 0; i < 3 * n; ++i) {
    EXPECT_NEAR(p1[i] - p0[i], c1[i] - c0[i], 1e-6) << "grain " << i / 3 + 1;
    moved = std::max(moved, std::abs(c1[i] - c0[i]));
  }
  EXPECT_GT(moved, 5e-6) << "the grains moved";
  // The scans show the grains where the truth puts them: each label's voxel centroid is its pose.
  for (const io::H5File* t : {&t0, &t1}) {
    const auto labels = io::read_image_as<std::uint32_t>(*t, "/labels");
    const auto& vs = labels.voxel_size();
    const auto& o = labels.origin();
    std::vector<Eigen::Vector3d> sum(n + 1, Eigen::Vector3d::Zero());
    std::vector<double> count(n + 1, 0.0);
    const auto sh = labels.shape();
    for (std::size_t z = 0; z < sh[0]; ++z)
      for (std::size_t y = 0; y < sh[1]; ++y)
        for (std::size_t x = 0; x < sh[2]; ++x)
          if (const auto l = labels(z, y, x)) {
            sum[l] += Eigen::Vector3d(o[2] + x * vs[2], o[1] + y * vs[1], o[0] + z * vs[0]);
            count[l] += 1.0;
          }
    const auto p = t == &t0 ? p0 : p1;
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_GT(count[i + 1], 0.0) << "grain " << i + 1 << " is in the image";
      const Eigen::Vector3d c = sum[i + 1] / count[i + 1];
      EXPECT_LT((c - Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2])).norm(), 0.35 * vs[0]) << "grain " << i + 1;
    }
  }
  // Contacts carry the simulation's forces: every loaded pair touches, compressive along its normal.
  const auto force = t1.read<double>("/contacts/force"), normal = t1.read<double>("/contacts/normal");
  const auto touching = t1.read<std::uint8_t>("/contacts/touching");
  std::size_t loaded = 0;
  for (std::size_t c = 0; c < touching.size(); ++c) {
    const Eigen::Vector3d f(force[3 * c], force[3 * c + 1], force[3 * c + 2]), nrm(normal[3 * c], normal[3 * c + 1], normal[3 * c + 2]);
    if (f.norm() == 0.0) continue;
    ++loaded;
    EXPECT_TRUE(touching[c]) << "contact " << c;
    EXPECT_GT(f.dot(nrm), 0.0) << "contact " << c << ": the force on the higher grain pushes it away";
  }
  EXPECT_GT(loaded, n) << "a loaded packing carries more contacts than grains";
  EXPECT_EQ(loaded, series["scans"][1]["force_pairs"].get<std::size_t>());
  EXPECT_GT(t1.attr_double("/", "stress_ratio"), 1.0);
  // The test's whole curve is in every truth, from the start of shearing; each scan sits on it.
  for (const io::H5File* t : {&t0, &t1}) {
    const auto strain = t->read<double>("/loading/axial_strain"), ratio = t->read<double>("/loading/stress_ratio");
    const auto volumetric = t->read<double>("/loading/volumetric_strain");
    ASSERT_GT(strain.size(), 10u);
    ASSERT_EQ(ratio.size(), strain.size());
    ASSERT_EQ(volumetric.size(), strain.size());
    EXPECT_TRUE(std::is_sorted(strain.begin(), strain.end()));
    EXPECT_NEAR(strain.back(), 0.01, 5e-4);
    const double at = t->attr_double("/", "axial_strain");
    const auto nearest = std::min_element(strain.begin(), strain.end(),
                                          [&](double a, double b) { return std::abs(a - at) < std::abs(b - at); }) - strain.begin();
    // (Within a step's change: the frame's strain is measured after the step whose row it takes.)
    EXPECT_NEAR(ratio[nearest], t->attr_double("/", "stress_ratio"), 0.02 * ratio[nearest]);
    EXPECT_NEAR(volumetric[nearest], t->attr_double("/", "volumetric_strain"), 1e-4);
  }
}

// The bundled default series is a simulated triaxial test: at least 4 scans to at least 10 %
// axial strain with one step of 5 % or more, each truth on the test's curve with its contact
// forces, the whole folder within the 20 MB (decimal) budget.
TEST(Ctsynth, BundledSandSmallIsASimulatedTriaxialTestWithinItsBudget) {
  const fs::path series = fs::path(GRAINTWIN_SOURCE_DIR) / "sample_volumes" / "sand_small";
  std::uintmax_t bytes = 0;
  for (const auto& e : fs::directory_iterator(series)) bytes += e.is_regular_file() ? e.file_size() : 0;
  EXPECT_LE(bytes, 20000000u);  // 20 MB
  std::vector<double> strains;
  for (std::size_t k = 0; fs::exists(series / fmt::format("truth_{:03d}.h5", k)); ++k) {
    SCOPED_TRACE(k);
    ASSERT_TRUE(fs::exists(series / fmt::format("scan_{:03d}.h5", k)));
    const io::H5File t = io::open_kind(series / fmt::format("truth_{:03d}.h5", k), "ground_truth");
    EXPECT_EQ(t.attr_string("/", "loading").value_or(""), "simulated");
    strains.push_back(t.attr_double("/", "axial_strain"));
    const auto curve_strain = t.read<double>("/loading/axial_strain"), curve_ratio = t.read<double>("/loading/stress_ratio");
    ASSERT_EQ(curve_ratio.size(), curve_strain.size());
    ASSERT_GT(curve_strain.size(), 100u);
    EXPECT_GE(curve_strain.back(), strains.back() - 1e-3);
    const auto force = t.read<double>("/contacts/force");
    EXPECT_EQ(force.size(), t.read<double>("/contacts/normal").size());
    EXPECT_GT(std::count_if(force.begin(), force.end(), [](double f) { return f != 0.0; }), 0);
  }
  ASSERT_GE(strains.size(), 4u);
  EXPECT_GE(strains.back(), 0.10 - 1e-3);
  double largest_step = 0.0;
  for (std::size_t k = 1; k < strains.size(); ++k) largest_step = std::max(largest_step, strains[k] - strains[k - 1]);
  EXPECT_GE(largest_step, 0.05 - 1e-3);
}

TEST(Ctsynth, SimulatedLoadingRefusesWhatItCannotRunBeforeAnyWork) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const std::string scene = (dir / "scene.toml").string(), out = (dir / "out").string(), tri = write_loading_scene(dir.path()).string();
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "simulated"}, 2, "--triaxial-scene");
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--triaxial-scene", tri}, 2, "--loading simulated");
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "simulated", "--triaxial-scene", tri, "--grain-shape", "angular"},
                             2, "angular");
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "simulated", "--triaxial-scene", tri, "--strains", "0"}, 2,
                             "above 0");
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "pushed"}, 2, "prescribed or simulated");
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "simulated", "--triaxial-scene", (dir / "nope.toml").string()},
                             2, "is not a readable file");
  // The scene is an input: the output folder may not replace it, even with --force.
  test::expect_clean_failure("ctsynth", dir, {scene, tri, "--force", "--loading", "simulated", "--triaxial-scene", tri}, 2,
                             "triaxial.toml");
  std::ofstream(dir / "stages.toml") << "[run]\nduration = 1e-3\n";
  test::expect_clean_failure("ctsynth", dir, {scene, out, "--loading", "simulated", "--triaxial-scene", (dir / "stages.toml").string()},
                             2, "[triaxial]");
}

TEST(Ctsynth, OverfullSceneFailsClearlyAndWritesNothing) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), (dir / "out").string(), "--solid-fraction", "0.78"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("0.74"), std::string::npos) << r.err;
  EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"scene.toml"}));
}

TEST(Ctsynth, UnknownSceneKeyIsAUsageError) {
  test::TempDir dir;
  write_scene(dir / "scene.toml", "grain-colour = \"red\"\n");
  const auto r = run_tool("ctsynth", {(dir / "scene.toml").string(), (dir / "out").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("grain-colour"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Ctsynth, MissingSceneIsAUsageError) {
  test::TempDir dir;
  const auto r = run_tool("ctsynth", {(dir / "nope.toml").string(), (dir / "out").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope.toml"), std::string::npos) << r.err;
}

// Every option and scene key is a finite number in a stated range, checked before any grain is
// made: NaN blur crashed, a huge blur or sample hung or ran out of memory, a huge grey scale wrote a
// saturated scan without a word. Each is refused at once, naming the option and the range or fix.
TEST(Ctsynth, OptionsOutsideTheirRangeAreRefusedBeforeAnyWork) {
  test::TempDir dir;
  write_scene(dir / "scene.toml");
  const std::string scene = (dir / "scene.toml").string(), out = (dir / "out").string();
  const auto refused = [&](const std::vector<std::string>& options, const std::vector<std::string>& says) {
    std::vector<std::string> args{scene, out};
    args.insert(args.end(), options.begin(), options.end());
    const auto r = run_tool("ctsynth", args);
    EXPECT_EQ(r.exit_code, 2) << options[0] << "\n" << r.err;
    for (const auto& s : says) EXPECT_NE(r.err.find(s), std::string::npos) << options[0] << ": " << s << "\n" << r.err;
    EXPECT_EQ(r.err.find("std::"), std::string::npos) << r.err;
    EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"scene.toml"})) << options[0];
  };
  refused({"--blur", "nan"}, {"--blur", "[0, 20] voxels", "not nan"});
  refused({"--blur", "1e6"}, {"--blur", "[0, 20] voxels", "not 1e6"});
  refused({"--noise=-inf"}, {"--noise", "[0, 10]"});
  refused({"--diameter", "10m"}, {"--diameter", "[10 um, 1 m]"});
  refused({"--d50", "0"}, {"--d50", "[1 um, 100 mm]"});
  refused({"--strains", "0,0.5"}, {"--strains", "[0, 0.5)"});
  refused({"--sh-degree", "2.5"}, {"--sh-degree", "whole number in [2, 30]"});
  refused({"--box", "1mm,nan,1mm", "--container", "box"}, {"--box", "finite length"});
  // Inside every range but too large together: the scans alone would be petabytes.
  refused({"--diameter", "1m", "--height", "1m"}, {"ctsynth needs about", "voxels", "--voxel-size"});
  // Hundreds of millions of micron grains in a small sample: the advice is the grain sizes.
  refused({"--d-min", "1um", "--d50", "2um", "--d-max", "3um"}, {"ctsynth needs about", "grains", "give larger grains (--d-min, --d50"});
  // Grey levels that would saturate uint16, or leave no contrast.
  refused({"--angular-facets", "12,8"}, {"--angular-facets", "MIN <= MAX"});
  refused({"--angular-facets", "3,8"}, {"--angular-facets", "[4, 64]"});
  refused({"--angular-dent-depth", "0.5"}, {"--angular-dent-depth", "[0, 0.3]"});
  refused({"--grain-shape", "crushed"}, {"--grain-shape", "angular"});
  refused({"--non-star-share", "1.5"}, {"--non-star-share", "[0, 1]"});
  refused({"--non-star-share", "0.2"}, {"--non-star-share applies to angular grains only"});
  refused({"--grain-shape", "library"}, {"--grain-shape library needs --library SHAPES.h5 and --library-labels LABELS.h5"});
  refused({"--library", "shapes.h5"}, {"--library and --library-labels go with --grain-shape library"});
  refused({"--grey-scale", "1e12"}, {"--grey-scale", "(0, 1e+06]"});
  refused({"--grey-scale", "1e6"}, {"--grey-scale 1e+06", "65535", "at most 80713"});
  refused({"--grey-grain", "0.05"}, {"--grey-grain 0.05 is not above --grey-void 0.1"});
  refused({"--grey-scale", "1e-3"}, {"same value", "at least 1.54"});
  // A correlation length must be 0 or a length its random lattice over the sample can afford.
  refused({"--nonaffine-correlation=-1mm"}, {"nonaffine correlation length must be 0"});
  refused({"--nonaffine-correlation", "nan"}, {"--nonaffine-correlation", "finite length"});
  refused({"--nonaffine-correlation", "1nm"}, {"too short for a sample", "give at least"});
  // The scene file's keys are the same options, with the same checks.
  write_scene(dir / "scene.toml", "blur = 1e6\n");
  refused({"-q"}, {"--blur", "[0, 20] voxels"});
}
