#pragma once
// Label image against ctsynth ground truth: which true grains a segmentation reproduces. The one
// scoring rule of segmentation: validate's error budget and the benchmarks (ct2labels_accuracy_bench,
// shapes2tracks_bench) use it.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "graintwin/core/volume.hpp"

namespace graintwin::validate {

/// A true grain is matched when one label covers it with IoU >= 0.8 (above 0.5 a match is
/// necessarily one-to-one).
inline constexpr double kIouMatched = 0.8;

/// How one true grain came out.
enum class LabelOutcome { matched, split, merged, split_and_merged, missed, boundary };
const char* name(LabelOutcome o);

struct TruthGrain {
  std::uint32_t label = 0;       ///< true label
  std::uint64_t voxels = 0;
  double best_iou = 0.0;
  std::uint32_t best_label = 0;  ///< the label of the best IoU (0: none overlaps)
  LabelOutcome outcome = LabelOutcome::missed;
};

/// Each label has a home grain (the true grain, or the background, holding most of its voxels)
/// and each true grain a home label (likewise): a grain that is home to two or more labels is
/// over-segmented (split); a grain whose home label is home-label of another grain too is
/// under-segmented (merged); a grain mostly left unlabelled is missed; an unmatched grain that is
/// none of these has a poor boundary. Labels whose home is the background are spurious.
struct MatchResult {
  std::vector<TruthGrain> grains;         ///< true grains present in the truth volume, by label
  std::vector<std::uint32_t> home_grain;  ///< by label (index 0 unused): its home grain, 0 = background
  std::size_t labels = 0, spurious = 0;
  std::size_t count(LabelOutcome o) const;
  std::size_t matched() const { return count(LabelOutcome::matched); }
  std::size_t split() const { return count(LabelOutcome::split) + count(LabelOutcome::split_and_merged); }
  std::size_t merged() const { return count(LabelOutcome::merged) + count(LabelOutcome::split_and_merged); }
  double matched_share() const { return grains.empty() ? 0.0 : static_cast<double>(matched()) / grains.size(); }
  /// By label (index 0 unused): the true label it faithfully reproduces (IoU >= 0.8), else 0.
  std::vector<std::uint32_t> faithful_grain() const;
};

/// Scores `pred` against `truth` (same shape; DataError otherwise).
MatchResult match_labels(const Volume<std::uint32_t>& truth, const Volume<std::uint32_t>& pred);

}  // namespace graintwin::validate
