// What validate reads and writes: a truth_NNN.h5 read back as ctsynth wrote it (read_ground_truth,
// the kind's own reader), validation.json written and read back with NaN as null, its summary over
// scans and increments, and damaged or foreign files refused in one sentence naming them.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/validate/validation_file.hpp"
#include "support/run_tool.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::validate;
namespace fs = std::filesystem;

namespace {

synth::GroundTruth small_truth(bool simulated) {
  synth::GroundTruth t;
  t.scan_index = 2, t.axial_strain = 0.02, t.sample_height = 1e-3, t.sample_radius = 4e-4;
  t.solid_fraction = 0.6, t.void_ratio = 2.0 / 3.0, t.contact_tolerance = 1e-7;
  t.labels = test::label_balls({12, 12, 20}, {{6, 6, 5, 4}, {6, 6, 14, 4}});
  t.poses.resize(2);
  t.poses[1].position = Eigen::Vector3d(1e-4, 2e-4, 3e-4);
  t.poses[1].orientation = Eigen::Quaterniond(0.5, 0.5, 0.5, 0.5);
  t.volume = {1e-12, 2e-12}, t.equivalent_diameter = {1e-4, 1.2e-4}, t.sphericity = {0.9, 0.8}, t.aspect_ratio = {1.1, 1.3};
  t.sh_degree = 1;
  t.sh_coeffs = Eigen::MatrixXd::Constant(2, 4, 1e-4);
  t.sh_coeffs_body = Eigen::MatrixXd::Constant(2, 4, 2e-4);
  t.sh_invariants = Eigen::MatrixXd::Constant(2, 2, 3e-4);
  t.contacts = {{1, 2, 5e-8, {1e-4, 0, 0}, {1, 0, 0}, true}};
  if (simulated) {
    t.simulated = true;
    t.contact_force = {{0.5, 0, 0}};
    t.stress_ratio = 3.0, t.volumetric_strain = -0.001;
    t.loading_curve = {{0.0, 0.01, 0.02}, {1.0, 2.5, 3.0}, {0.0, 0.0005, -0.001}};
  }
  return t;
}

Validation small_validation() {
  Validation v;
  v.run = "runs/x", v.series = "sample_volumes/x";
  for (int k = 0; k < 2; ++k) {
    ScanValidation sc;
    sc.name = "scan_00" + std::to_string(k);
    sc.segmentation.true_grains = 10, sc.segmentation.right = 8 + k;
    sc.segmentation.void_ratio = 0.7, sc.segmentation.void_ratio_true = 0.65 + 0.1 * k;
    sc.has_contacts = k == 0;
    sc.contacts.true_touching = 20, sc.contacts.found = 15, sc.contacts.false_found = 2;
    sc.contacts.normal_error_deg = {1.0, 3.0, 5.0};
    sc.contacts.anisotropy = 0.3, sc.contacts.anisotropy_true = 0.25;
    sc.has_shapes = true;
    sc.shapes.invariant_error_median = 0.1 * (k + 1);
    sc.shapes.invariant_error_by_degree = {0.01, kNaN, 0.2};
    sc.shapes.volume_error = {-0.02 * (k + 1)};
    v.scans.push_back(sc);
  }
  TrackingScore t;
  t.from = 0, t.to = 1, t.targets = 9, t.right = 7, t.wrong = 1, t.lost = 1;
  t.displacement_error_m = {1e-6, 2e-6, 4e-6}, t.displacement_error_rel_median = 0.05;
  t.rotation_error_deg = {2.0};
  v.tracking.push_back(t);
  DeformationScore d;
  d.from = 0, d.to = 1, d.d2min_spearman = 0.8, d.eps_q_spearman = kNaN, d.cluster_jaccard = 0.5;
  d.d2min = {1, 2}, d.d2min_true = {1.5, kNaN};
  v.deformation.push_back(d);
  v.history = {"ctsynth ...", "validate ..."};
  return v;
}

}  // namespace

TEST(ValidateFiles, GroundTruthReadsBackWhatCtsynthWrote) {
  test::TempDir dir;
  for (bool simulated : {false, true}) {
    const synth::GroundTruth t = small_truth(simulated);
    const fs::path p = dir / (simulated ? "sim.h5" : "pre.h5");
    synth::write_ground_truth(p, t, {"test"});
    const synth::GroundTruth r = synth::read_ground_truth(p);
    EXPECT_EQ(r.scan_index, 2);
    EXPECT_DOUBLE_EQ(r.void_ratio, 2.0 / 3.0);
    EXPECT_EQ(r.labels.values(), t.labels.values());
    ASSERT_EQ(r.poses.size(), 2u);
    EXPECT_EQ(r.poses[1].position, t.poses[1].position);
    EXPECT_DOUBLE_EQ(r.poses[1].orientation.w(), 0.5);
    EXPECT_EQ(r.volume, t.volume);
    EXPECT_EQ(r.sh_degree, 1);
    EXPECT_EQ(r.sh_invariants, t.sh_invariants);
    ASSERT_EQ(r.contacts.size(), 1u);
    EXPECT_EQ(r.contacts[0].high, 2u);
    EXPECT_TRUE(r.contacts[0].touching);
    EXPECT_EQ(r.simulated, simulated);
    EXPECT_EQ(r.loading_curve.stress_ratio, t.loading_curve.stress_ratio);
    if (simulated) EXPECT_DOUBLE_EQ(r.stress_ratio, 3.0);
  }
}

TEST(ValidateFiles, GroundTruthReaderRefusesOtherKindsAndDamagedTables) {
  test::TempDir dir;
  // A contact naming a grain that does not exist.
  {
    synth::GroundTruth bad = small_truth(false);
    bad.contacts[0].high = 7;
    synth::write_ground_truth(dir / "bad.h5", bad, {"test"});
    try {
      synth::read_ground_truth(dir / "bad.h5");
      FAIL() << "a contact of an unknown grain was read";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.message()).find("bad.h5"), std::string::npos) << e.message();
    }
  }
  // NaN in a position.
  {
    synth::GroundTruth bad = small_truth(false);
    bad.poses[0].position.x() = NAN;
    synth::write_ground_truth(dir / "nan.h5", bad, {"test"});
    EXPECT_THROW(synth::read_ground_truth(dir / "nan.h5"), DataError);
  }
  // A file of another kind.
  std::ofstream(dir / "text.h5") << "not hdf5";
  EXPECT_THROW(synth::read_ground_truth(dir / "text.h5"), UsageError);
}

TEST(ValidateFiles, ValidationJsonRoundTripsWithNaNAsNull) {
  test::TempDir dir;
  const Validation v = small_validation();
  write_validation(dir / "v.json", v);
  std::ifstream in(dir / "v.json");
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("\"eps_q_spearman\": null"), std::string::npos);
  const Validation r = read_validation(dir / "v.json");
  ASSERT_EQ(r.scans.size(), 2u);
  EXPECT_EQ(r.scans[1].name, "scan_001");
  EXPECT_EQ(r.scans[1].segmentation.right, 9u);
  EXPECT_TRUE(r.scans[0].has_contacts);
  EXPECT_FALSE(r.scans[1].has_contacts);
  EXPECT_EQ(r.scans[0].contacts.normal_error_deg, v.scans[0].contacts.normal_error_deg);
  EXPECT_TRUE(std::isnan(r.scans[0].shapes.invariant_error_by_degree[1]));
  ASSERT_EQ(r.tracking.size(), 1u);
  EXPECT_EQ(r.tracking[0].wrong, 1u);
  EXPECT_EQ(r.tracking[0].displacement_error_m, v.tracking[0].displacement_error_m);
  ASSERT_EQ(r.deformation.size(), 1u);
  EXPECT_TRUE(std::isnan(r.deformation[0].eps_q_spearman));
  EXPECT_TRUE(std::isnan(r.deformation[0].d2min_true[1]));
  EXPECT_FALSE(r.twin.simulated);
  EXPECT_TRUE(std::isnan(r.twin.stress_ratio_rms_rel));
  EXPECT_EQ(r.history, v.history);
}

TEST(ValidateFiles, SummaryPoolsScansAndIncrements) {
  const BudgetSummary s = summarise(small_validation());
  EXPECT_DOUBLE_EQ(s.grains_right, 17.0 / 20.0);
  EXPECT_NEAR(s.void_ratio_error_max_abs, 0.05, 1e-12);     // |0.7 - 0.65| and |0.7 - 0.75|
  EXPECT_DOUBLE_EQ(s.contacts_found_share, 15.0 / 20.0);     // scan 0 only has contacts
  EXPECT_EQ(s.contacts_false, 2u);
  EXPECT_DOUBLE_EQ(s.normal_error_median_deg, 3.0);
  EXPECT_NEAR(s.anisotropy_error_max_abs, 0.05, 1e-12);
  EXPECT_NEAR(s.invariant_error_median, 0.15, 1e-12);        // mean of the scans' 0.1 and 0.2
  EXPECT_DOUBLE_EQ(s.volume_error_median, -0.02);             // the upper middle of (-0.02, -0.04)
  EXPECT_EQ(s.tracking_right, 7u);
  EXPECT_EQ(s.tracking_lost, 1u);
  EXPECT_DOUBLE_EQ(s.displacement_error_median_m, 2e-6);
  EXPECT_DOUBLE_EQ(s.rotation_error_median_deg, 2.0);
  EXPECT_DOUBLE_EQ(s.d2min_spearman, 0.8);
  EXPECT_TRUE(std::isnan(s.eps_q_spearman));
  EXPECT_DOUBLE_EQ(s.cluster_jaccard, 0.5);
}

TEST(ValidateFiles, ReaderRefusesForeignAndDamagedFiles) {
  test::TempDir dir;
  std::ofstream(dir / "other.json") << R"({"kind": "report"})";
  EXPECT_THROW(read_validation(dir / "other.json"), UsageError);
  std::ofstream(dir / "text.json") << "not json";
  EXPECT_THROW(read_validation(dir / "text.json"), UsageError);
  EXPECT_THROW(read_validation(dir / "absent.json"), UsageError);
  write_validation(dir / "v.json", small_validation());
  std::ifstream in(dir / "v.json");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const auto at = text.find("\"wrong\": 1");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 10, "\"wrong\": \"one\"");
  std::ofstream(dir / "damaged.json") << text;
  try {
    read_validation(dir / "damaged.json");
    FAIL() << "a damaged count was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.message()).find("damaged.json"), std::string::npos);
    EXPECT_NE(std::string(e.message()).find("\"wrong\""), std::string::npos);
  }
}
