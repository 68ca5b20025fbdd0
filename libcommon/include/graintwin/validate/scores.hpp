#pragma once
// The lines of the pipeline's error budget (docs/validate.md): each stage's output scored against
// ctsynth's ground truth, one plain function per line. Grains are compared through the label ->
// true grain map of each scan (faithful_grain of validate/label_match): a label that reproduces a
// true grain with IoU >= 0.8 stands for it; every other label has no true counterpart and is left
// out of the lines that compare grains.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/micro/analysis.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/segment/sample_region.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "graintwin/validate/label_match.hpp"

namespace graintwin::validate {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The value below which `share` (in [0, 1]) of `values` lie: linear interpolation between the
/// order statistics at rank share x (n - 1). NaN for no values.
double quantile(std::vector<double> values, double share);

/// Spearman's rank correlation of the pairs (x_i, y_i) where both are finite: Pearson's r of their
/// ranks, tied values taking their mean rank. NaN with fewer than 3 pairs or a constant side.
double spearman(const std::vector<double>& x, const std::vector<double>& y);

/// Segmentation of one scan.
struct SegmentationScore {
  std::size_t true_grains = 0;  ///< true grains in the truth's label image
  std::size_t right = 0, split = 0, merged = 0, missed = 0, boundary = 0;  ///< LabelOutcome counts (split and merged both count a grain that is both)
  std::size_t labels = 0, spurious = 0;  ///< labels of the segmentation; those mostly on background
  double right_share = kNaN;             ///< right / true_grains
  /// e = V_void / V_solid of the segmentation (the labels file's measurement) and of the truth's
  /// label image, both from voxel-centre counts in the labels file's sample cylinder.
  double void_ratio = kNaN, void_ratio_true = kNaN;
};

/// The void ratio of the truth's label image (a voxel centre inside a grain is solid) in `region`,
/// by segment::void_ratio: the same count ct2labels makes of its own mask.
segment::VoidRatio true_void_ratio(const Volume<std::uint32_t>& truth_labels, const segment::Cylinder& region);

/// The segmentation line from the label match and the two void ratios.
SegmentationScore score_segmentation(const MatchResult& match, double void_ratio, double void_ratio_true);

/// Contacts of one scan, between faithfully segmented grains.
struct ContactScore {
  std::size_t true_touching = 0;  ///< true touching contacts whose two grains are both faithfully segmented
  std::size_t found = 0;          ///< of those, the ones the contacts file holds (accepted) between their labels
  std::size_t missed = 0;         ///< true_touching - found
  std::size_t false_found = 0;    ///< accepted contacts between faithful labels whose true grains do not touch
  double found_share = kNaN;      ///< found / true_touching
  /// Per found contact: the angle (degrees) between its measured normal and the true one, both
  /// oriented from the lower to the higher true label.
  std::vector<double> normal_error_deg;
  double normal_error_median_deg = kNaN, normal_error_p90_deg = kNaN;
  /// Fabric anisotropy a (contacts::fabric_tensor) of the found contacts' measured normals, and of
  /// the true normals of every true touching contact of the scan.
  double anisotropy = kNaN, anisotropy_true = kNaN;
};

/// `true_of_label`: by label of the segmentation (index 0 unused), the true label it faithfully
/// reproduces, else 0 (MatchResult::faithful_grain).
/// With `all_contacts` every contact of the table counts, else only the accepted ones (those
/// labels2contacts counts in Z, the fabric and the roses).
ContactScore score_contacts(const std::vector<synth::TrueContact>& truth, const contacts::ContactTable& measured,
                            const std::vector<std::uint32_t>& true_of_label, bool all_contacts = false);

/// Shapes of one scan's faithfully segmented grains.
struct ShapeScore {
  std::size_t grains = 0;  ///< faithful grains with a shapes row
  /// Per degree n = 0..L (L the smaller of the two files' degrees): the median over the grains of
  /// |R_n / R_n,true - 1|, R_n = ||c_n|| the rotation invariant; a grain counts up to its own degree.
  std::vector<double> invariant_error_by_degree;
  /// The median of |R_n / R_n,true - 1| over the grains and the degrees n >= 2 (n = 0 is the size,
  /// the volume line's; R_1 about the centroid is near zero, so its relative error means nothing).
  double invariant_error_median = kNaN;
  double volume_error_median = kNaN;    ///< median of V / V_true - 1
  double diameter_error_median = kNaN;  ///< median of d / d_true - 1, d = (6 V / pi)^(1/3)
  std::vector<double> volume_error;     ///< per grain: V / V_true - 1
};

ShapeScore score_shapes(const synth::GroundTruth& truth, const std::vector<shape::GrainShape>& grains,
                        const std::vector<std::uint32_t>& true_of_label);

/// Tracking from scan `from` to scan `to` (consecutive). The targets are the true grains faithfully
/// segmented in both scans; each is right (the track holding its label in `from` holds its label in
/// `to`), wrong (that track holds another label in `to`) or lost (no track carries it on).
struct TrackingScore {
  std::size_t from = 0, to = 0;
  std::size_t targets = 0, right = 0, wrong = 0, lost = 0;
  /// Right tracks: |u - u_true| (m) of the centroid's increment, and over |u_true|.
  std::vector<double> displacement_error_m;
  double displacement_error_median_m = kNaN, displacement_error_p90_m = kNaN, displacement_error_rel_median = kNaN;
  /// Right tracks with a defined rotation step: the angle (degrees) of R_true^-1 R.
  std::vector<double> rotation_error_deg;
  double rotation_error_median_deg = kNaN, rotation_error_p90_deg = kNaN;
};

TrackingScore score_tracking(const track::TracksTable& tracks, std::size_t from, std::size_t to,
                             const std::vector<std::uint32_t>& true_of_label_from,
                             const std::vector<std::uint32_t>& true_of_label_to, const synth::GroundTruth& truth_from,
                             const synth::GroundTruth& truth_to);

/// The parameters of the run's micro-mechanics (its /micro/parameters) that the truth's are
/// computed with; no defaults of their own (micro::MicroOptions holds those).
struct MicroParameters {
  double radius_d50 = 0.0;
  std::size_t min_neighbours = 0;
  double top_fraction = 0.0;
  double contact_factor = 0.0;  ///< tracks2micro links clusters by the same factor
};
/// DataError naming `name` when the JSON lacks one of them.
MicroParameters micro_parameters(const std::string& parameters_json, const std::string& name);

/// D2min, eps_q and the high-D2min clusters of one increment against the truth's.
struct DeformationScore {
  std::size_t from = 0, to = 0;
  std::size_t grains = 0;  ///< run grains rightly tracked over the increment with D2min defined in both
  double d2min_spearman = kNaN, eps_q_spearman = kNaN;
  std::vector<double> d2min, d2min_true;  ///< the compared pairs
  /// Top-fraction cluster members among the rightly tracked grains: the run's, the truth's, and
  /// their Jaccard index |A n B| / |A u B|.
  std::size_t cluster_members = 0, cluster_members_true = 0, cluster_common = 0;
  double cluster_jaccard = kNaN;
};

/// The truth's micro-mechanics of the increment: micro::local_deformation of the true centroids
/// (every true grain; neighbourhood radius_d50 x the truth's d50 of the first state) and
/// micro::cluster_statistics of its D2min, as tracks2micro computes them.
struct TrueDeformation {
  std::vector<micro::LocalDeformation> grains;  ///< by true label - 1
  std::vector<std::int32_t> cluster;            ///< by true label - 1
};
TrueDeformation true_deformation(const synth::GroundTruth& from, const synth::GroundTruth& to, const MicroParameters& parameters);

/// Increment `increment` of the run's micro tables against `truth`. Grains of the run count when
/// their labels in both states reproduce the same true grain.
DeformationScore score_deformation(const micro::MicroTables& run, std::size_t increment, const TrueDeformation& truth,
                                   const std::vector<std::uint32_t>& true_of_label_from,
                                   const std::vector<std::uint32_t>& true_of_label_to);

/// The twin's shearing curve against the truth's (a simulated series' /loading curve).
struct TwinScore {
  bool simulated = false;  ///< the truth has a loading curve; otherwise every number is NaN
  /// Over the truth's points inside the common axial-strain range, the simulation interpolated
  /// linearly at the truth's strains: RMS of (q_sim - q_true) / q_true of the stress ratio q, the
  /// largest |eps_v,sim - eps_v,true|, and the range's end.
  double stress_ratio_rms_rel = kNaN, volumetric_strain_max_abs = kNaN, axial_strain_max = kNaN;
  std::vector<double> axial_strain, stress_ratio_true, stress_ratio, volumetric_strain_true, volumetric_strain;
};
TwinScore score_twin(const synth::LoadingCurve& truth, const fdem::TriaxialSeries& simulation);

}  // namespace graintwin::validate
