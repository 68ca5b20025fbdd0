#pragma once
// Matching the grains of two scans (docs/methods.md, matching and tracking).
//   paper     the CT-FDEM paper's Algorithm 1 exactly: candidates within 3 d50 of the reference
//             grain's own position (C1), volume change at most 10 % (C2), score D(i, j) = the
//             L2 distance of the SH rotation invariants, conflicts resolved by letting the smallest
//             score keep a contested grain while the others take their next best until no grain is
//             taken twice (deferred acceptance with reference grains proposing).
//   improved  (default) seeds on pairs whose neighbours move the same way, predicts each grain's
//             position from matched grains around it (robust global affine, then local weighted
//             affine, iterated), looks for candidates in a window of a few residual standard
//             deviations around the prediction, scores them by a combined cost (invariant
//             distance, volume change, position residual, each normalised by its spread over the
//             pairs judged right by a two-component mixture) and solves one global minimum-cost
//             assignment on the sparse candidate graph in which every reference grain may also be
//             "lost", at a fixed cost or at the cost of explaining it, by mass balance, as merged
//             or cut by the other scan's segmentation; each match's confidence comes from its
//             cost against its alternatives and from a forward-backward check.
//   nearest   baseline: the paper's algorithm scoring candidates by centroid distance, no volume filter.
//   volume    baseline: the paper's algorithm scoring candidates by relative volume change.
// Candidates always come from a spatial index (PointGrid), never from all pairs.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/shape/shapes_file.hpp"

namespace graintwin::track {

/// One scan's grains as the matchers see them (a view of a shapes file).
struct ScanGrains {
  std::vector<std::uint32_t> label;
  std::vector<Eigen::Vector3d> centroid;  ///< m, (x, y, z)
  std::vector<double> volume;             ///< m^3
  /// N x (L+1), row i = ||R_n|| of grain i, n = 0..L (m).
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> invariants;
  double d50 = 0.0;                       ///< m, of this scan's size distribution
  std::size_t size() const { return centroid.size(); }
};

/// The matchers' view of a shapes file. DataError if a grain has a non-finite centroid or a
/// non-positive volume.
ScanGrains scan_grains(const shape::ShapesFile& shapes);
/// The grains `index` of a scan (same d50), e.g. the lost grains offered to a later scan.
ScanGrains subset(const ScanGrains& scan, const std::vector<std::size_t>& index);

/// D(i, j) = sqrt(sum_n (||R_n^i|| - ||R_n^j||)^2) over the degrees both scans have.
double invariant_distance(const ScanGrains& a, std::size_t i, const ScanGrains& b, std::size_t j);

enum class Method { paper, improved, nearest, volume };
/// "paper", "improved", "nearest", "volume".
std::string method_name(Method m);
/// UsageError listing the names for anything else.
Method parse_method(const std::string& name);

struct MatchOptions {
  Method method = Method::improved;
  double window_d50 = 3.0;     ///< C1: candidate radius in d50 of the reference scan (improved: first pass)
  /// C2: largest |v_j - v_i| / v_i of a candidate; negative = no filter. Unset: 0.10 for paper and
  /// volume (the paper's); none for improved, whose cost weighs the volume change (segmentation
  /// changes a grain's volume by more than 10 % between scans more often than that filter allows,
  /// and the cost alone still reports merged or split grains lost); nearest never filters.
  std::optional<double> volume_tol;
  // The improved mode.
  int passes = 2;              ///< prediction + assignment passes (the first seeded by the bootstrap pairs)
  double local_radius_d50 = 3.0;  ///< neighbourhood of the local affine fit
  double window_sigmas = 6.0;  ///< candidate window = this many position residual spreads ...
  double min_window_d50 = 0.5; ///< ... but at least this (and at most window_d50)
  /// Cost of leaving a reference grain unmatched. A right match costs about 5 (like chi^2 with 5
  /// degrees of freedom); 144 was chosen on ctsynth series (docs/shapes2tracks.md): it keeps grains
  /// whose segmentation changed a little and still reports merged or split grains lost. A grain
  /// without a plausible match whose damage mass balance explains is lost at that explanation's
  /// cost when it is lower.
  double lost_cost = 144.0;
  bool backward_check = true;  ///< match the scans the other way round too; disagreeing matches get confidence 0
};

/// The volume filter options.method uses (see MatchOptions::volume_tol); negative = none.
double volume_filter(const MatchOptions& options);

/// Figures of one matching, for logs and benchmarks.
struct MatchDiagnostics {
  double mean_candidates = 0.0;   ///< candidates per reference grain in the final pass
  std::size_t anchors = 0;        ///< improved: pairs the first prediction rested on (the bootstrap's)
  double sigma_position = 0.0;    ///< improved: global position residual spread (m, per component)
  double sigma_shape = 0.0;       ///< improved: spread of D / ||R_0|| over the matches
  double sigma_volume = 0.0;      ///< improved: spread of ln(v_j / v_i)
  std::size_t backward_disagreements = 0;  ///< matches the backward pass did not confirm
  /// improved: reference grains whose lost cost a merge or cut explanation lowered (final pass)
  std::size_t explained_as_damaged = 0;
};

struct Matching {
  std::vector<int> partner;          ///< per reference grain: index in the other scan, -1 = lost
  std::vector<double> score;         ///< paper: D; nearest: distance (m); volume: |dv|/v; improved: combined cost; NaN if lost
  std::vector<double> confidence;    ///< in [0, 1], NaN if lost (see docs/shapes2tracks.md)
  std::vector<Eigen::Vector3d> predicted;  ///< where each reference grain was looked for
  MatchDiagnostics diagnostics;
  std::size_t matched() const;
};

/// Known pairs between two scans (e.g. tracks present in both), which seed the improved mode's
/// prediction in place of its own first pass.
struct KnownPairs {
  std::vector<std::size_t> ref, def;  ///< indices into the two full scans
};

/// Matches `ref` to `def` with options.method. With `known` (improved mode only; ignored
/// otherwise), the displacement field and the cost scales start from those pairs (whose scans are
/// `known_ref` and `known_def`), as when lost grains of scan k-1 are offered to scan k+1.
/// UsageError for invalid options.
Matching match_grains(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& options);
Matching match_grains(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& options,
                      const ScanGrains& known_ref, const ScanGrains& known_def, const KnownPairs& known);

}  // namespace graintwin::track
