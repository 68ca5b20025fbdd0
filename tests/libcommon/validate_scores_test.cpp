// The error budget's lines against phantoms whose scores are known by construction: a segmentation
// that merges two known grains, contacts found, missed and false with a known normal error, shape
// invariants off by a known share, a track swap with known displacement and rotation errors, the
// truth's D2min and clusters against themselves and against a reordering, a twin's curve against a
// known offset; and the rank statistics.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/validate/label_match.hpp"
#include "graintwin/validate/scores.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::validate;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// Three balls in a row, the first two touching.
std::vector<test::Ball> three_balls() { return {{12, 12, 8, 5}, {12, 12, 18, 5}, {12, 12, 30, 5}}; }

}  // namespace

TEST(ValidateStatistics, QuantileInterpolatesBetweenOrderStatistics) {
  EXPECT_DOUBLE_EQ(quantile({4, 1, 3, 2, 5}, 0.5), 3.0);
  EXPECT_DOUBLE_EQ(quantile({1, 2, 3, 4, 5}, 0.9), 4.6);
  EXPECT_DOUBLE_EQ(quantile({7}, 0.9), 7.0);
  EXPECT_TRUE(std::isnan(quantile({}, 0.5)));
}

TEST(ValidateStatistics, SpearmanIsPearsonOfRanksWithTiesAveraged) {
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {10, 100, 1000, 1e4}), 1.0);  // monotonic, not linear
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  // Ranks x (1, 2, 3, 4), y (1, 2.5, 2.5, 4): r = 4.5 / sqrt(5 x 4.5).
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {1, 2, 2, 3}), 4.5 / std::sqrt(5.0 * 4.5), 1e-12);
  // Non-finite pairs are left out; fewer than 3 pairs is undefined.
  EXPECT_DOUBLE_EQ(spearman({1, 2, NAN, 3}, {3, 2, 1, 1}), -1.0);
  EXPECT_TRUE(std::isnan(spearman({1, 2}, {1, 2})));
}

TEST(ValidateSegmentation, AMergeOfTwoKnownGrainsCountsBothMergedAndTheThirdRight) {
  const auto balls = three_balls();
  const Volume<std::uint32_t> truth = test::label_balls({24, 24, 40}, balls);
  Volume<std::uint32_t> merged = truth;
  for (std::uint32_t& v : merged.values()) v = v == 2 ? 1 : (v == 3 ? 2 : v);
  const MatchResult m = match_labels(truth, merged);
  const SegmentationScore s = score_segmentation(m, 1.5, 1.25);
  EXPECT_EQ(s.true_grains, 3u);
  EXPECT_EQ(s.right, 1u);
  EXPECT_EQ(s.merged, 2u);
  EXPECT_EQ(s.split, 0u);
  EXPECT_EQ(s.missed, 0u);
  EXPECT_EQ(s.labels, 2u);
  EXPECT_DOUBLE_EQ(s.right_share, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(s.void_ratio, 1.5);
  EXPECT_DOUBLE_EQ(s.void_ratio_true, 1.25);
  // Label 2 reproduces true grain 3; label 1 reproduces none.
  const auto faithful = m.faithful_grain();
  ASSERT_EQ(faithful.size(), 3u);
  EXPECT_EQ(faithful[1], 0u);
  EXPECT_EQ(faithful[2], 3u);
}

TEST(ValidateSegmentation, TrueVoidRatioCountsVoxelCentresInTheRegion) {
  Volume<std::uint32_t> truth({4, 10, 10});
  for (std::size_t z = 0; z < 4; ++z)
    for (std::size_t x = 0; x < 10; ++x) truth(z, 0, x) = 1, truth(z, 1, x) = 1;  // 2 of 10 rows solid
  segment::Cylinder all;
  all.radius = std::numeric_limits<double>::infinity();
  EXPECT_DOUBLE_EQ(true_void_ratio(truth, all).e, 4.0);
  segment::Cylinder lower = all;
  lower.z_max = 1.0;  // slices 0 and 1 only: the same share
  EXPECT_DOUBLE_EQ(true_void_ratio(truth, lower).e, 4.0);
}

TEST(ValidateContacts, FoundMissedFalseAndTheNormalErrorOrientedByTrueLabels) {
  // True contacts: (1, 2) touching along x, (1, 3) touching along z, (2, 3) a gap.
  std::vector<synth::TrueContact> truth(3);
  truth[0] = {1, 2, 0.0, {0, 0, 0}, {1, 0, 0}, true};
  truth[1] = {1, 3, 0.0, {0, 0, 0}, {0, 0, 1}, true};
  truth[2] = {2, 3, -1e-5, {0, 0, 0}, {0, 1, 0}, false};
  // The segmentation's labels 1, 2, 3 reproduce true grains 2, 1, 3; label 4 none.
  const std::vector<std::uint32_t> true_of_label{0, 2, 1, 3, 0};
  contacts::ContactTable c;
  const auto add = [&](std::uint32_t a, std::uint32_t b, Vec3 n, std::uint8_t accepted) {
    c.pair.push_back(a), c.pair.push_back(b), c.normal.push_back(n), c.area.push_back(1.0), c.accepted.push_back(accepted);
  };
  // Labels (1, 2) are true (2, 1): their normal from label 1 to 2 is the true normal reversed, 10 degrees off.
  add(1, 2, Vec3{-std::cos(10 * kDeg), std::sin(10 * kDeg), 0.0}, 1);
  add(1, 3, Vec3{0, 1, 0}, 1);   // true (2, 3): not touching, a false contact
  add(3, 4, Vec3{0, 0, 1}, 1);   // label 4 reproduces no grain: not scored
  add(2, 3, Vec3{0, 0, 1}, 0);  // true (1, 3), but not accepted
  const ContactScore s = score_contacts(truth, c, true_of_label);
  EXPECT_EQ(s.true_touching, 2u);
  EXPECT_EQ(s.found, 1u);
  EXPECT_EQ(s.missed, 1u);
  EXPECT_EQ(s.false_found, 1u);
  EXPECT_DOUBLE_EQ(s.found_share, 0.5);
  ASSERT_EQ(s.normal_error_deg.size(), 1u);
  EXPECT_NEAR(s.normal_error_deg[0], 10.0, 1e-9);
  EXPECT_NEAR(s.normal_error_median_deg, 10.0, 1e-9);
  // The true fabric of normals x and z: phi = diag(1/2, 0, 1/2), a = 15 (1/2 - 1) / (-8 + 5/2 - 5) = 5/7.
  EXPECT_NEAR(s.anisotropy_true, 5.0 / 7.0, 1e-12);
  // Counting every contact finds the unaccepted one too.
  const ContactScore all = score_contacts(truth, c, true_of_label, true);
  EXPECT_EQ(all.found, 2u);
  EXPECT_EQ(all.missed, 0u);
  EXPECT_NEAR(all.normal_error_median_deg, 10.0, 1e-9);  // the upper middle of (0, 10)
}

TEST(ValidateShapes, InvariantAndVolumeErrorsOfFaithfulGrainsOnly) {
  synth::GroundTruth truth;
  truth.volume = {1e-9, 2e-9};
  truth.sh_invariants = Eigen::MatrixXd(2, 4);
  truth.sh_invariants << 10, 0.1, 2, 1,  //
      20, 0.2, 4, 2;
  std::vector<shape::GrainShape> grains(3);
  grains[0].label = 5, grains[0].sh_degree = 3, grains[0].volume = 1.1e-9;
  grains[0].invariants = Eigen::Vector4d(11, 1.0, 2.2, 0.9);  // errors 0.1, 9, 0.1, 0.1
  grains[1].label = 6, grains[1].sh_degree = 2, grains[1].volume = 2e-9 * 0.729;
  grains[1].invariants = Eigen::Vector4d(18, 0.2, 4.8, 0.0);  // errors 0.1, 0, 0.2; degree 3 is above its own
  grains[2].label = 7, grains[2].sh_degree = 3, grains[2].volume = 1.0;  // reproduces no true grain
  grains[2].invariants = Eigen::Vector4d(1, 1, 1, 1);
  const std::vector<std::uint32_t> true_of_label{0, 0, 0, 0, 0, 1, 2, 0};
  const ShapeScore s = score_shapes(truth, grains, true_of_label);
  EXPECT_EQ(s.grains, 2u);
  ASSERT_EQ(s.invariant_error_by_degree.size(), 4u);
  EXPECT_NEAR(s.invariant_error_by_degree[0], 0.1, 1e-12);
  EXPECT_NEAR(s.invariant_error_by_degree[1], 9.0, 1e-12);  // the upper middle of (9, 0)
  EXPECT_NEAR(s.invariant_error_by_degree[2], 0.2, 1e-12);
  EXPECT_NEAR(s.invariant_error_by_degree[3], 0.1, 1e-12);
  EXPECT_NEAR(s.invariant_error_median, 0.1, 1e-12);  // degrees >= 2: the middle of (0.1, 0.1, 0.2)
  EXPECT_NEAR(s.volume_error_median, 0.1, 1e-12);     // (0.1, -0.271)
  EXPECT_NEAR(s.diameter_error_median, std::cbrt(1.1) - 1.0, 1e-12);
}

namespace {
/// Truth of `n` grains at x = 0, 1, 2, ... mm, rotated `angle` degrees about z.
synth::GroundTruth row_of_grains(std::size_t n, double shift_m, double angle_deg) {
  synth::GroundTruth t;
  t.poses.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    t.poses[i].position = Eigen::Vector3d(1e-3 * double(i) + shift_m, 0, 0);
    t.poses[i].orientation = Eigen::Quaterniond(Eigen::AngleAxisd(angle_deg * kDeg, Eigen::Vector3d::UnitZ()));
  }
  return t;
}
}  // namespace

TEST(ValidateTracking, ASwapIsTwoWrongAndErrorsAreThoseOfTheRightTrack) {
  const synth::GroundTruth before = row_of_grains(4, 0.0, 0.0), after = row_of_grains(4, 10e-6, 30.0);
  // Scan 0: labels 1..4 reproduce true grains 1..4. Scan 1: labels 1..3 reproduce 1..3, label 4 none.
  const std::vector<std::uint32_t> map0{0, 1, 2, 3, 4}, map1{0, 1, 2, 3, 0};
  track::TracksTable t;
  t.tracks = 4, t.scans = 2;
  t.label = {1, 1, 2, 3, 3, 2, 4, 0};  // track 0 right, tracks 1 and 2 swapped, track 3 lost (its grain is no target)
  t.centroid.assign(4 * 2 * 3, 0.0);
  t.rotation_step.assign(4 * 2 * 4, 0.0);
  t.rotation_defined.assign(4 * 2, 0);
  // Track 0 moves 13 um along x (3 um more than the truth's 10) and turns 20 degrees about z (10 short).
  t.centroid[3] = 13e-6;
  const Eigen::Quaterniond step(Eigen::AngleAxisd(20 * kDeg, Eigen::Vector3d::UnitZ()));
  t.rotation_step[4] = step.w(), t.rotation_step[7] = step.z();
  t.rotation_defined[1] = 1;
  const TrackingScore s = score_tracking(t, 0, 1, map0, map1, before, after);
  EXPECT_EQ(s.targets, 3u);
  EXPECT_EQ(s.right, 1u);
  EXPECT_EQ(s.wrong, 2u);
  EXPECT_EQ(s.lost, 0u);
  ASSERT_EQ(s.displacement_error_m.size(), 1u);
  EXPECT_NEAR(s.displacement_error_m[0], 3e-6, 1e-15);
  EXPECT_NEAR(s.displacement_error_rel_median, 0.3, 1e-9);
  ASSERT_EQ(s.rotation_error_deg.size(), 1u);
  EXPECT_NEAR(s.rotation_error_deg[0], 10.0, 1e-9);
  // A track that stops is lost.
  t.label[3] = 0;
  const TrackingScore lost = score_tracking(t, 0, 1, map0, map1, before, after);
  EXPECT_EQ(lost.right, 1u);
  EXPECT_EQ(lost.wrong, 1u);
  EXPECT_EQ(lost.lost, 1u);
}

namespace {
/// A 5 x 5 x 5 lattice of 1 mm grains, sheared with a non-affine nudge per grain.
std::pair<synth::GroundTruth, synth::GroundTruth> sheared_lattice() {
  synth::GroundTruth a, b;
  for (int i = 0; i < 125; ++i) {
    const Eigen::Vector3d p(1e-3 * (i % 5), 1e-3 * (i / 5 % 5), 1e-3 * (i / 25));
    synth::PackedGrain g;
    g.position = p;
    a.poses.push_back(g);
    g.position = p + Eigen::Vector3d(0.02 * p.z(), 0, 0) + 2e-5 * Eigen::Vector3d(std::sin(1.3 * i), std::cos(2.1 * i), std::sin(0.7 * i * i));
    b.poses.push_back(g);
    a.volume.push_back(std::numbers::pi / 6 * 1e-9);
  }
  b.volume = a.volume;
  return {a, b};
}
}  // namespace

TEST(ValidateDeformation, TheTruthAgainstItselfAndAgainstAReordering) {
  const auto [a, b] = sheared_lattice();
  const MicroParameters p{1.5, 3, 0.1, 1.1};
  const TrueDeformation truth = true_deformation(a, b, p);
  ASSERT_EQ(truth.grains.size(), 125u);
  std::size_t selected = 0, defined = 0;
  for (std::int32_t c : truth.cluster) selected += c >= 0;
  for (const auto& g : truth.grains) defined += g.status == micro::DeformationStatus::ok;
  EXPECT_EQ(defined, 125u);  // every grain has neighbours within 1.5 d50
  EXPECT_EQ(selected, 12u);  // the top 10 % of 125, rounded down

  // A run whose labels are the true labels reversed, with the truth's values: a perfect score.
  micro::MicroTables run;
  run.grains = 125;
  run.states.resize(2);
  run.increments.resize(1);
  run.increments[0].from = 0, run.increments[0].to = 1;
  std::vector<std::uint32_t> true_of_label(127, 0);
  for (std::size_t i = 0; i < 125; ++i) {
    const auto label = static_cast<std::uint32_t>(125 - i);
    true_of_label[label] = static_cast<std::uint32_t>(i + 1);
    run.grain_label.push_back(label), run.grain_label.push_back(label);
    run.grain_d2min.push_back(truth.grains[i].d2min);
    run.grain_eps_q.push_back(truth.grains[i].eps_q);
    run.grain_cluster.push_back(truth.cluster[i]);
  }
  DeformationScore s = score_deformation(run, 0, truth, true_of_label, true_of_label);
  EXPECT_EQ(s.grains, 125u);
  EXPECT_DOUBLE_EQ(s.d2min_spearman, 1.0);
  EXPECT_DOUBLE_EQ(s.eps_q_spearman, 1.0);
  EXPECT_EQ(s.cluster_members, 12u);
  EXPECT_DOUBLE_EQ(s.cluster_jaccard, 1.0);

  // D2min negated: rank correlation -1. Cluster membership moved off 3 members: |A n B| = 9, |A u B| = 15.
  for (double& d : run.grain_d2min) d = -d;
  std::size_t moved = 0;
  for (std::size_t i = 0; i < 125 && moved < 3; ++i)
    if (run.grain_cluster[i] >= 0) run.grain_cluster[i] = -1, ++moved;
  for (std::size_t i = 0, added = 0; i < 125 && added < 3; ++i)
    if (truth.cluster[i] < 0) run.grain_cluster[i] = 0, ++added;
  s = score_deformation(run, 0, truth, true_of_label, true_of_label);
  EXPECT_DOUBLE_EQ(s.d2min_spearman, -1.0);
  EXPECT_EQ(s.cluster_common, 9u);
  EXPECT_DOUBLE_EQ(s.cluster_jaccard, 9.0 / 15.0);
}

TEST(ValidateTwin, RmsOfTheRelativeStressRatioOverTheCommonRange) {
  synth::LoadingCurve truth;
  for (int k = 0; k <= 10; ++k) {
    const double e = 0.01 * k;
    truth.axial_strain.push_back(e), truth.stress_ratio.push_back(2.0 + 100 * e), truth.volumetric_strain.push_back(-e);
  }
  // The simulation runs to 6 % only, its ratio 10 % above the truth's, its eps_v 0.001 off; rows
  // before shearing are NaN, the rows out of order.
  fdem::TriaxialSeries sim;
  for (int k : {3, 0, 6, 1, 2, 4, 5}) {
    const double e = 0.01 * k;
    sim.axial_strain.push_back(e), sim.stress_ratio.push_back(1.1 * (2.0 + 100 * e)), sim.volumetric_strain.push_back(-e + 0.001);
  }
  sim.axial_strain.push_back(NAN), sim.stress_ratio.push_back(NAN), sim.volumetric_strain.push_back(NAN);
  const TwinScore s = score_twin(truth, sim);
  EXPECT_TRUE(s.simulated);
  EXPECT_NEAR(s.stress_ratio_rms_rel, 0.1, 1e-12);
  EXPECT_NEAR(s.volumetric_strain_max_abs, 0.001, 1e-12);
  EXPECT_DOUBLE_EQ(s.axial_strain_max, 0.06);
  EXPECT_EQ(s.axial_strain.size(), 7u);
  // Prescribed loading has no curve: every number is null.
  const TwinScore none = score_twin({}, sim);
  EXPECT_FALSE(none.simulated);
  EXPECT_TRUE(std::isnan(none.stress_ratio_rms_rel));
}
