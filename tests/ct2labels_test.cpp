// ct2labels: CLI contract, the labels file it writes, the preview picture, its accuracy on the
// bundled sand_small scans against their ground truth, and every bad input the requirements list
// (empty, all-solid, constant, NaN, one-voxel grains, wrong kind) failing cleanly.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/validate/label_match.hpp"
#include "graintwin/validate/scores.hpp"
#include "support/cli_contract.hpp"
#include "support/golden.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

const std::vector<test::Ball> kBalls = test::jittered_lattice(3, 7.0, 13.0, 9.0, 0.8, 0.05, 21);

/// A uint16 scan of 27 touching spheres, 44^3 voxels of 20 um.
std::filesystem::path write_phantom(const test::TempDir& dir) {
  const Volume<float> f = test::scan_balls({44, 44, 44}, kBalls, 4, 0.03, {2e-5, 2e-5, 2e-5});
  const Volume<std::uint16_t> v = test::uint16_scan(f);
  io::write_volume_file(dir / "scan.h5", v, {"phantom"});
  return dir / "scan.h5";
}

template <class T>
std::filesystem::path write_constant(const test::TempDir& dir, const std::string& name, T value, Shape3 shape = {8, 8, 8}) {
  Volume<T> v(shape, {1e-5, 1e-5, 1e-5});
  for (auto& x : v.values()) x = value;
  io::write_volume_file(dir / name, v, {"constant"});
  return dir / name;
}

/// Width and height from a PNG's IHDR chunk.
std::pair<std::uint32_t, std::uint32_t> png_size(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  unsigned char h[24] = {};
  in.read(reinterpret_cast<char*>(h), 24);
  const auto be = [&](int o) { return std::uint32_t(h[o]) << 24 | std::uint32_t(h[o + 1]) << 16 | std::uint32_t(h[o + 2]) << 8 | h[o + 3]; };
  return {be(16), be(20)};
}

void fail(const test::TempDir& dir, const std::vector<std::string>& args, int code, const std::string& words) {
  test::expect_clean_failure("ct2labels", dir, args, code, words);
}

}  // namespace

TEST(Ct2labels, StandardCli) { test::expect_standard_cli("ct2labels"); }

TEST(Ct2labels, SegmentsAPhantomAndWritesTheLabelsFile) {
  test::TempDir dir;
  const auto scan = write_phantom(dir);
  const auto r = run_tool("ct2labels", {scan.string(), (dir / "labels.h5").string(), "--preview",
                                        (dir / "preview.png").string(), "--region", "volume"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("chosen from the image"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("27 grains"), std::string::npos) << r.err;

  const segment::LabelsFile l = segment::read_labels_file(dir / "labels.h5");
  EXPECT_EQ(l.grains.size(), kBalls.size());
  EXPECT_EQ(l.labels.shape(), (Shape3{44, 44, 44}));
  EXPECT_EQ(l.labels.voxel_size(), (Vec3{2e-5, 2e-5, 2e-5}));
  // Grain volumes: the spheres' (4/3 pi r^3), within the partial-volume error of a 7-voxel radius.
  for (const auto& g : l.grains) EXPECT_NEAR(g.volume_m3 / (4.0 / 3.0 * M_PI * std::pow(7 * 2e-5, 3)), 1.0, 0.2);
  const auto p = nlohmann::json::parse(l.parameters_json);
  EXPECT_EQ(p["threshold_method"], "otsu");
  EXPECT_EQ(p["marker_parameter_automatic"], true);
  EXPECT_GT(p["h_vox"].get<double>(), 0.0);
  EXPECT_EQ(p["grains"], 27);
  const io::H5File f = io::H5File::open(dir / "labels.h5");
  const auto history = io::read_history(f);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0], "phantom");
  EXPECT_NE(history[1].find("ct2labels"), std::string::npos);
  EXPECT_EQ(f.attr_string("/grains/volume", "units"), "m^3");
  // Preview: the axial slice (44 x 44) and the vertical section (44 x 44) side by side, 8 apart.
  EXPECT_EQ(png_size(dir / "preview.png"), (std::pair<std::uint32_t, std::uint32_t>{96, 44}));
}

// The defaults on the bundled series (sand_small: 20 voxels per d50, 5 % noise, a latex membrane),
// scored against ctsynth's truth by validate's one rule (IoU >= 0.8): the first scan and the most
// sheared one. The test holds the project's target (98 % of the grains right) and a void ratio
// within 2 % of the truth's, both counted by voxel centres in ct2labels' own cylinder;
// tests/data/ct2labels.json holds what the defaults measure, tightly.
TEST(Ct2labels, SegmentsTheBundledSandScansAsTheirTruthHasThem) {
  const std::filesystem::path series = std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "sample_volumes" / "sand_small";
  test::TempDir dir;
  test::Golden measured("ct2labels");
  for (const std::string scan : {"000", "003"}) {
    const auto r = run_tool("ct2labels", {(series / ("scan_" + scan + ".h5")).string(), (dir / "labels.h5").string(), "-q", "--force"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const segment::LabelsFile labels = segment::read_labels_file(dir / "labels.h5");
    const synth::GroundTruth truth = synth::read_ground_truth(series / ("truth_" + scan + ".h5"));
    const validate::SegmentationScore s =
        validate::score_segmentation(validate::match_labels(truth.labels, labels.labels), labels.sample.void_ratio.e,
                                     validate::true_void_ratio(truth.labels, labels.sample.region).e);
    EXPECT_GE(s.right_share, 0.98) << "scan " << scan;
    EXPECT_NEAR(s.void_ratio / s.void_ratio_true, 1.0, 0.02) << "scan " << scan;
    const std::string at = "scan_" + scan + "_";
    measured.check(at + "right_share", s.right_share);
    measured.check(at + "split", double(s.split));
    measured.check(at + "merged", double(s.merged));
    measured.check(at + "spurious_labels", double(s.spurious));
    measured.check(at + "void_ratio_over_true", s.void_ratio / s.void_ratio_true);
  }
}

TEST(Ct2labels, OptionsReachTheSegmentation) {
  test::TempDir dir;
  const auto scan = write_phantom(dir);
  const auto r = run_tool("ct2labels", {scan.string(), (dir / "l.h5").string(), "--markers", "peaks", "--d50", "0.28mm",
                                        "--threshold", "2000", "--denoise", "gaussian", "--connectivity", "18", "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "-q must silence the log: " << r.err;
  const auto p = nlohmann::json::parse(segment::read_labels_file(dir / "l.h5").parameters_json);
  EXPECT_EQ(p["markers"], "peaks");
  EXPECT_DOUBLE_EQ(p["min_distance_vox"].get<double>(), 7.0);  // d50 / 2 in voxels
  EXPECT_EQ(p["threshold"], 2000.0);
  EXPECT_EQ(p["connectivity"], 18);
  EXPECT_EQ(p["denoise"], "gaussian");
  EXPECT_EQ(p["grains"], 27);
}

TEST(Ct2labels, BadVolumesFailWithOneSentenceAndNoOutput) {
  test::TempDir dir;
  const std::string out = (dir / "labels.h5").string();
  // Constant: Otsu is undefined.
  const auto flat = write_constant<std::uint16_t>(dir, "flat.h5", 1000);
  fail(dir, {flat.string(), out}, 1, "constant");
  fail(dir, {flat.string(), out, "--preview", (dir / "p.png").string()}, 1, flat.string());
  // All solid and no solid under a given threshold.
  fail(dir, {flat.string(), out, "--threshold", "10"}, 1, "every voxel is solid");
  fail(dir, {flat.string(), out, "--threshold", "5000"}, 1, "no solid");
  // NaN in a float scan.
  Volume<float> nan({8, 8, 8}, {1e-5, 1e-5, 1e-5});
  nan(1, 2, 3) = std::numeric_limits<float>::quiet_NaN();
  io::write_volume_file(dir / "nan.h5", nan, {"nan"});
  fail(dir, {(dir / "nan.h5").string(), out}, 1, "NaN");
  // Grains of one voxel: specks on a void background.
  Volume<std::uint16_t> specks({12, 12, 12}, {1e-5, 1e-5, 1e-5});
  for (std::size_t z = 2; z < 12; z += 4)
    for (std::size_t y = 2; y < 12; y += 4)
      for (std::size_t x = 2; x < 12; x += 4) specks(z, y, x) = 3000;
  io::write_volume_file(dir / "specks.h5", specks, {"specks"});
  fail(dir, {(dir / "specks.h5").string(), out, "--denoise", "none", "--region", "volume"}, 1,
                       "no grain is left");
  // Empty volume.
  io::write_volume_file(dir / "empty.h5", Volume<std::uint16_t>({0, 8, 8}, {1e-5, 1e-5, 1e-5}), {"empty"});
  fail(dir, {(dir / "empty.h5").string(), out}, 1, "empty");
}

TEST(Ct2labels, WrongInputsAndOptionsAreUsageErrors) {
  test::TempDir dir;
  const auto scan = write_phantom(dir);
  const std::string out = (dir / "labels.h5").string();
  // A labels file is not a scan.
  ASSERT_EQ(run_tool("ct2labels", {scan.string(), out, "-q"}).exit_code, 0);
  fail(dir, {out, (dir / "again.h5").string()}, 2, "pass a scan");
  // Existing output without --force, and with it.
  fail(dir, {scan.string(), out}, 2, "--force");
  EXPECT_EQ(run_tool("ct2labels", {scan.string(), out, "-q", "--force"}).exit_code, 0);
  // uint32 scans, bad option values, a preview that is not PNG.
  const auto u32 = write_constant<std::uint32_t>(dir, "u32.h5", 7);
  fail(dir, {u32.string(), (dir / "x.h5").string()}, 2, "uint32");
  fail(dir, {scan.string(), (dir / "x.h5").string(), "--markers", "blobs"}, 2, "--markers");
  fail(dir, {scan.string(), (dir / "x.h5").string(), "--h", "-1"}, 2, "--h");
  fail(dir, {scan.string(), (dir / "x.h5").string(), "--connectivity", "8"}, 2, "connectivity");
  fail(dir, {scan.string(), (dir / "x.h5").string(), "--region", "cylinder"}, 2, "--cylinder");
  fail(dir, {scan.string(), (dir / "x.h5").string(), "--preview", (dir / "p.jpg").string()}, 2, ".png");
}

// Numeric options are finite and in range before anything is read; a Gaussian larger than the
// volume is refused from the header alone (sigma 1e6 on a 40 x 60 x 60 volume used to hang).
TEST(Ct2labels, OptionsOutsideTheirRangeAndKernelsLargerThanTheVolumeAreRefused) {
  test::TempDir dir;
  const auto small = write_constant<std::uint16_t>(dir, "small.h5", 1000, {40, 60, 60});
  const std::string out = (dir / "labels.h5").string();
  fail(dir, {small.string(), out, "--sigma-vox", "1e6"}, 2, "--sigma-vox: must be a finite number in (0, 20] voxels, not 1e6");
  fail(dir, {small.string(), out, "--sigma-vox", "nan"}, 2, "not nan");
  fail(dir, {small.string(), out, "--sigma-vox", "20"}, 2,
       "--sigma-vox 20 (a Gaussian cut at 3 sigma) spans 121 voxels, more than the volume (40 x 60 x 60 voxels, z y x)");
  fail(dir, {small.string(), out, "--threshold", "inf"}, 2, "--threshold: must be a finite number");
  fail(dir, {small.string(), out, "--open-vox", "1e9"}, 2, "[0, 50] voxels");
  fail(dir, {small.string(), out, "--min-distance-vox", "0"}, 2, "(0, 1000] voxels");
  fail(dir, {small.string(), out, "--min-volume-vox", "nan"}, 2, "--min-volume-vox");
  fail(dir, {small.string(), out, "--d50", "1km"}, 2, "unknown unit 'km'");
  fail(dir, {small.string(), out, "--region", "cylinder", "--cylinder", "0,0,2m"}, 2,
       "--cylinder radius must be a length in [1 um, 1 m], not 2m");
}

// A sample cylinder centred at or below zero is a valid region: the volume's origin is arbitrary.
TEST(Ct2labels, CylinderCentresAtZeroAndBelowAreAccepted) {
  test::TempDir dir;
  const Volume<float> f = test::scan_balls({44, 44, 44}, kBalls, 4, 0.03, {2e-5, 2e-5, 2e-5});
  Volume<std::uint16_t> v(f.shape(), f.voxel_size(), {-4.3e-4, -4.3e-4, -4.3e-4});  // centred on the origin
  for (std::size_t i = 0; i < f.size(); ++i) v.values()[i] = static_cast<std::uint16_t>(std::lround(4000.0 * f.values()[i]));
  io::write_volume_file(dir / "centred.h5", v, {"centred phantom"});
  for (const std::string& centre : {std::string("0,0"), std::string("-0.01mm,0um")}) {
    const auto out = dir / "labels.h5";
    const auto r = run_tool("ct2labels", {(dir / "centred.h5").string(), out.string(), "-q", "--force", "--region",
                                          "cylinder", "--cylinder", centre + ",0.4mm"});
    ASSERT_EQ(r.exit_code, 0) << centre << ": " << r.err;
    const auto labels = segment::read_labels_file(out);
    EXPECT_NEAR(labels.sample.region.centre_x, centre[0] == '-' ? -1e-5 : 0.0, 1e-12) << centre;
    EXPECT_EQ(labels.sample.region.centre_y, 0.0);
    EXPECT_DOUBLE_EQ(labels.sample.region.radius, 4e-4);
    EXPECT_GT(labels.sample.void_ratio.e, 0.0);
  }
}

TEST(Ct2labels, AThousandThreadsGiveTheSameGrains) {
  // Far more threads than processors, as the --threads cap allows: no crash, and per-thread
  // histograms and label tables stop at the processors.
  test::TempDir dir;
  const auto scan = write_phantom(dir);
  const auto one = run_tool("ct2labels", {scan.string(), (dir / "one.h5").string(), "-q", "-j", "1"});
  const auto many = run_tool("ct2labels", {scan.string(), (dir / "many.h5").string(), "-q", "-j", "1024"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  ASSERT_EQ(many.exit_code, 0) << many.err;
  const segment::LabelsFile a = segment::read_labels_file(dir / "one.h5"), b = segment::read_labels_file(dir / "many.h5");
  ASSERT_EQ(b.grains.size(), a.grains.size());
  for (std::size_t i = 0; i < a.grains.size(); ++i) EXPECT_EQ(b.grains[i].voxels, a.grains[i].voxels) << "grain " << i + 1;
}
