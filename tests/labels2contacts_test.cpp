// labels2contacts: CLI contract, the kind=contacts file and the .vtp it writes (read back by h5py-
// like checks and by VTK's own reader), the refined normals with a grey volume, and every bad input
// failing cleanly with nothing left behind.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/edt.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/markers.hpp"
#include "graintwin/segment/threshold.hpp"
#include "graintwin/segment/watershed.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

constexpr double kVoxel = 2e-5;

/// Writes a labels file for `labels` (grain table from the image) with a one-line history.
std::filesystem::path write_labels(const test::TempDir& dir, const std::string& name, Volume<std::uint32_t> labels) {
  segment::LabelsFile c;
  c.grains = segment::grain_table(labels);
  c.labels = std::move(labels);
  c.parameters_json = "{}";
  segment::write_labels_file(dir / name, c, {"made by labels2contacts_test"});
  return dir / name;
}

/// Three boxes in a row along x: 1 | 2 | 3, sharing 4 x 5 faces; box 3 is cut by the volume edge.
Volume<std::uint32_t> three_boxes() {
  Volume<std::uint32_t> v({8, 9, 16}, {kVoxel, kVoxel, kVoxel});
  for (std::size_t z = 2; z < 6; ++z)
    for (std::size_t y = 2; y < 7; ++y)
      for (std::size_t x = 1; x < 16; ++x) v(z, y, x) = x < 6 ? 1 : x < 11 ? 2 : 3;
  return v;
}

/// Two touching spheres of 14 voxels diameter along (1, 2, 2) / 3 (z, y, x), scanned by the spam
/// protocol, and their watershed labels: the grey file, the labels file and the true normal (x, y, z).
struct SpherePair {
  std::filesystem::path scan, labels;
  std::array<double, 3> normal;
};
SpherePair write_sphere_pair(const test::TempDir& dir) {
  const double r = 7.0, d[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3};
  const double c = 19.3;
  Volume<float> grey = test::scan_balls({40, 40, 40},
                                        {{c - d[0] * r, c - d[1] * r, c - d[2] * r, r}, {c + d[0] * r, c + d[1] * r, c + d[2] * r, r}},
                                        3, 0.03, {kVoxel, kVoxel, kVoxel});
  const auto edt = segment::distance_transform(segment::binarise(grey, 0.5));
  io::write_volume_file(dir / "scan.h5", grey, {"spheres"});
  return {dir / "scan.h5", write_labels(dir, "labels.h5", segment::watershed(edt, segment::h_maxima_markers(edt, 1.0))),
          {d[2], d[1], d[0]}};
}

}  // namespace

TEST(Labels2contacts, StandardCli) { test::expect_standard_cli("labels2contacts"); }

TEST(Labels2contacts, LabelsOnlyGiveTheContactsFileWithExactNormalsAndTheNetwork) {
  test::TempDir dir;
  const auto labels = write_labels(dir, "labels.h5", three_boxes());
  const auto r = run_tool("labels2contacts", {labels.string(), (dir / "c.h5").string(), "--vtk",
                                              (dir / "c.vtp").string(), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::open_kind(dir / "c.h5", "contacts");
  std::vector<hsize_t> dims;
  EXPECT_EQ(f.read<std::uint32_t>("/contacts/pair", &dims), (std::vector<std::uint32_t>{1, 2, 2, 3}));
  EXPECT_EQ(dims, (std::vector<hsize_t>{2, 2}));
  const auto normal = f.read<double>("/contacts/normal");
  for (int k = 0; k < 2; ++k) EXPECT_NEAR(normal[3 * k], 1.0, 1e-12) << "along +x, from low to high";
  EXPECT_EQ(f.attr_string("/contacts/normal", "units").value_or(""), "1");
  const auto area = f.read<double>("/contacts/area");
  EXPECT_NEAR(area[0], 20 * kVoxel * kVoxel, 1e-18);
  EXPECT_EQ(f.attr_string("/contacts/area", "units").value_or(""), "m^2");
  const auto branch = f.read<double>("/contacts/branch");
  EXPECT_NEAR(branch[0], 5 * kVoxel, 1e-15);
  EXPECT_TRUE(std::isnan(f.read<double>("/contacts/confidence")[0])) << "no grey volume: unknown";
  EXPECT_EQ(f.read<std::uint8_t>("/contacts/fit_status"), (std::vector<std::uint8_t>{4, 4}));
  EXPECT_EQ(f.read<std::uint8_t>("/contacts/accepted"), (std::vector<std::uint8_t>{1, 1}));
  EXPECT_EQ(f.read<std::uint64_t>("/contacts/voxels"), (std::vector<std::uint64_t>{20, 20, 20, 20}));
  EXPECT_EQ(f.read<std::uint32_t>("/grains/coordination"), (std::vector<std::uint32_t>{1, 2, 1}));
  // Grain 3 reaches the x = 15 face: left out of the histogram (Z = 1 once, Z = 2 once).
  EXPECT_EQ(f.read<std::uint64_t>("/coordination/count"), (std::vector<std::uint64_t>{0, 1, 1}));
  EXPECT_DOUBLE_EQ(f.attr_doubles("/coordination", "mean").at(0), 1.5);
  // All normals along x: phi = diag(1, 0, 0), a = 15 / -3 = -5.
  EXPECT_NEAR(f.read<double>("/fabric/normal/tensor")[0], 1.0, 1e-12);
  EXPECT_NEAR(f.read<double>("/fabric/normal/anisotropy").at(0), -5.0, 1e-12);
  EXPECT_EQ(f.read<std::uint64_t>("/fabric/normal/count").at(0), 2u);
  const auto counts = f.read<std::uint64_t>("/rose/normal/counts", &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{9, 36}));
  EXPECT_EQ(counts[8 * 36 + 0], 2u) << "theta 90 degrees, azimuth 0";
  const auto history = io::read_history(f);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0], "made by labels2contacts_test");
  EXPECT_EQ(history[1].rfind("labels2contacts ", 0), 0u);

  const auto s = test::vtk_summary(dir / "c.vtp");
  EXPECT_EQ(s["verts"], 2);
  EXPECT_EQ(s["lines"], 2);
  EXPECT_EQ(s["points"], 5);  // 2 contact points + 3 grain centroids
  EXPECT_EQ(s["cell_data"]["pair"]["components"], 2);
  EXPECT_EQ(s["point_data"]["normal"]["components"], 3);
  EXPECT_EQ(s["cell_data"]["kind"]["range"][1], 1.0);
}

TEST(Labels2contacts, GreyVolumeRefinesTheNormalAndGivesAConfidence) {
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  const auto r = run_tool("labels2contacts", {p.labels.string(), p.scan.string(), (dir / "c.h5").string(), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::open_kind(dir / "c.h5", "contacts");
  ASSERT_EQ(f.read<std::uint32_t>("/contacts/pair").size(), 2u);
  EXPECT_EQ(f.read<std::uint8_t>("/contacts/fit_status").at(0), 0u);
  const auto n = f.read<double>("/contacts/normal"), pca = f.read<double>("/contacts/normal_pca");
  const auto err = [&](const std::vector<double>& v) {
    const double c = std::abs(v[0] * p.normal[0] + v[1] * p.normal[1] + v[2] * p.normal[2]);
    return std::acos(std::min(1.0, c)) * 180.0 / M_PI;
  };
  EXPECT_LT(err(n), 1.5);
  EXPECT_LT(err(n), err(pca));
  EXPECT_GT(f.read<double>("/contacts/confidence").at(0), 0.5);
  EXPECT_NEAR(f.read<double>("/contacts/gap").at(0) / kVoxel, 0.0, 0.2);
  EXPECT_EQ(f.attr_string("/contacts/gap", "units").value_or(""), "m");
  EXPECT_EQ(io::read_history(f).size(), 3u) << "both inputs' histories and this run";

  // --no-refine keeps the PCA normal.
  const auto plain = run_tool("labels2contacts", {p.labels.string(), p.scan.string(), (dir / "p.h5").string(), "-q", "--no-refine"});
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  const io::H5File g = io::open_kind(dir / "p.h5", "contacts");
  EXPECT_EQ(g.read<double>("/contacts/normal"), g.read<double>("/contacts/normal_pca"));
  EXPECT_EQ(g.read<std::uint8_t>("/contacts/fit_status").at(0), 4u);
}

TEST(Labels2contacts, BadInputsFailInOneSentenceAndLeaveNothing) {
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  const auto out = (dir / "c.h5").string();
  const auto fails = [&](const std::vector<std::string>& args, int code, const std::string& says) {
    const auto before = test::list_dir(dir.path());
    const auto r = run_tool("labels2contacts", args);
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
    EXPECT_EQ(test::list_dir(dir.path()), before) << "a failed run must leave no output";
  };
  // Wrong kinds: the scan as labels, the labels as the scan.
  fails({p.scan.string(), out}, 2, "expected kind=labels");
  fails({p.labels.string(), p.labels.string(), out}, 2, "expected kind=volume");
  // A scan of another shape.
  io::write_volume_file(dir / "small.h5", Volume<float>({10, 10, 10}, {kVoxel, kVoxel, kVoxel}), {});
  fails({p.labels.string(), (dir / "small.h5").string(), out}, 2, "pass the scan the labels were made from");
  // NaN grey values.
  Volume<float> nan = io::read_image_as<float>(io::H5File::open(p.scan), "/volume");
  nan(3, 4, 5) = std::numeric_limits<float>::quiet_NaN();
  io::write_volume_file(dir / "nan.h5", nan, {});
  fails({p.labels.string(), (dir / "nan.h5").string(), out}, 1, "NaN");
  // No grains at all.
  write_labels(dir, "empty.h5", Volume<std::uint32_t>({6, 6, 6}, {kVoxel, kVoxel, kVoxel}));
  fails({(dir / "empty.h5").string(), out}, 1, "holds no grains");
  // Output rules: extension, existing file without --force.
  fails({p.labels.string(), (dir / "c.txt").string()}, 2, "must end in .h5");
  fails({p.labels.string(), out, "--vtk", (dir / "c.vtk").string()}, 2, "must end in .vtp");
  ASSERT_EQ(run_tool("labels2contacts", {p.labels.string(), out, "-q"}).exit_code, 0);
  fails({p.labels.string(), out}, 2, "--force");
}

TEST(Labels2contacts, ReadsThePipelineParameters) {
  test::TempDir dir;
  const auto labels = write_labels(dir, "labels.h5", three_boxes());
  const auto r = run_tool("labels2contacts", {labels.string(), (dir / "c.h5").string(), "--config",
                                              std::string(GRAINTWIN_SOURCE_DIR) + "/pipelines/params/labels2contacts.toml"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "c.h5"));
}

TEST(Labels2contacts, GrainTableShorterThanTheImageIsRefused) {
  test::TempDir dir;
  segment::LabelsFile c;
  c.labels = three_boxes();
  c.grains = segment::grain_table(c.labels);
  c.grains.pop_back();  // label 3 keeps its voxels but loses its row
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "short.h5", c, {"a table one row short"});
  test::expect_clean_failure("labels2contacts", dir, {(dir / "short.h5").string(), (dir / "c.h5").string()}, 1,
                             (dir / "short.h5").string() + " does not match its label image: 1 grain of the label image "
                             "has no row in the grain table (label 3); rewrite the file with ct2labels");
}

TEST(Labels2contacts, GreyVolumeWithoutContrastIsRefused) {
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  // Every voxel 0: no fit can converge, so every confidence would be NaN and every contact counted.
  io::write_volume_file(dir / "black.h5", Volume<std::uint16_t>({40, 40, 40}, {kVoxel, kVoxel, kVoxel}), {"all zero"});
  test::expect_clean_failure("labels2contacts", dir, {p.labels.string(), (dir / "black.h5").string(), (dir / "c.h5").string()},
                             1, (dir / "black.h5").string() + " holds the grey value 0 in every voxel, so there is no contrast");
}

TEST(Labels2contacts, SummaryCountsUnknownConfidencesApart) {
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  const auto r = run_tool("labels2contacts", {p.labels.string(), p.scan.string(), (dir / "c.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::open_kind(dir / "c.h5", "contacts");
  const auto confidence = f.read<double>("/contacts/confidence");
  std::size_t above = 0, unknown = 0;
  for (double c : confidence) above += c >= 0.5, unknown += std::isnan(c);
  const std::string line = std::to_string(above + unknown) + " of " + std::to_string(confidence.size()) +
                           " contacts are counted in Z and the fabric: " + std::to_string(above) +
                           " with confidence >= 0.5 and " + std::to_string(unknown) + " not fitted (confidence unknown)";
  EXPECT_NE(r.err.find(line), std::string::npos) << r.err;
}

// NaN passed every range check (--gap-tolerance-vox nan accepted every contact), a huge window hung,
// and a huge rose asked for more memory than exists: all are refused before any work.
TEST(Labels2contacts, OptionsOutsideTheirRangeAndWindowsLargerThanTheVolumeAreRefused) {
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  const std::vector<std::string> in{p.labels.string(), p.scan.string(), (dir / "c.h5").string()};
  const auto refused = [&](const std::vector<std::string>& options, const std::string& says) {
    test::expect_option_refused("labels2contacts", dir, in, options, says);
  };
  refused({"--gap-tolerance-vox", "nan"}, "--gap-tolerance-vox: must be a finite number in (0, 10] voxels, not nan");
  refused({"--min-confidence", "nan"}, "--min-confidence: must be a finite number in [0, 1], not nan");
  refused({"--window-vox", "1e6"}, "--window-vox: must be a finite number in [0, 30] voxels, not 1e6");
  refused({"--window-vox", "30"}, "--window-vox 30 (with its 2-voxel margin) spans 65 voxels, more than the volume (40 x 40 x 40");
  refused({"--theta-bins", "1000000000"}, "--theta-bins: must be a whole number in [1, 90]");
  refused({"--phi-bins", "0"}, "--phi-bins: must be a whole number in [1, 360]");
  refused({"--min-voxels", "-1"}, "--min-voxels: must be a whole number in [1, 1e+09] voxels");
  // CLI11's PositiveNumber printed its bounds in full: "not in range 0.000000 to 1797693134862315708...".
  const auto r = run_tool("labels2contacts", {in[0], in[1], in[2], "--gap-tolerance-vox=-1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("(0, 10] voxels, not -1"), std::string::npos) << r.err;
  EXPECT_LT(r.err.size(), 200u) << r.err;
  // Without the grey volume no window is fitted, so only its range is checked.
  EXPECT_EQ(run_tool("labels2contacts", {p.labels.string(), (dir / "plain.h5").string(), "-q", "--window-vox", "30"}).exit_code, 0);
}

TEST(Labels2contacts, AThousandThreadsGiveTheSameContacts) {
  // Far more threads than processors, as the --threads cap allows: no crash, the same contacts,
  // normals and confidences (each contact is independent, the pair sums are integers).
  test::TempDir dir;
  const SpherePair p = write_sphere_pair(dir);
  for (const char* j : {"1", "1024"}) {
    const auto r = run_tool("labels2contacts", {p.labels.string(), p.scan.string(), (dir / (std::string("c") + j + ".h5")).string(),
                                                "-q", "-j", j});
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const io::H5File a = io::open_kind(dir / "c1.h5", "contacts"), b = io::open_kind(dir / "c1024.h5", "contacts");
  EXPECT_EQ(b.read<std::uint32_t>("/contacts/pair"), a.read<std::uint32_t>("/contacts/pair"));
  EXPECT_EQ(b.read<double>("/contacts/normal"), a.read<double>("/contacts/normal"));
  EXPECT_EQ(b.read<double>("/contacts/confidence"), a.read<double>("/contacts/confidence"));
}
