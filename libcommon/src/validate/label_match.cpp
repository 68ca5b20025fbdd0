#include "graintwin/validate/label_match.hpp"

#include <algorithm>
#include <unordered_map>

#include "graintwin/core/error.hpp"

namespace graintwin::validate {

const char* name(LabelOutcome o) {
  switch (o) {
    case LabelOutcome::matched: return "matched";
    case LabelOutcome::split: return "over-segmented";
    case LabelOutcome::merged: return "under-segmented";
    case LabelOutcome::split_and_merged: return "over- and under-segmented";
    case LabelOutcome::missed: return "missed";
    case LabelOutcome::boundary: return "boundary (IoU < 0.8, not split or merged)";
  }
  return "?";
}

std::size_t MatchResult::count(LabelOutcome o) const {
  return static_cast<std::size_t>(
      std::count_if(grains.begin(), grains.end(), [&](const TruthGrain& g) { return g.outcome == o; }));
}

std::vector<std::uint32_t> MatchResult::faithful_grain() const {
  std::vector<std::uint32_t> out(home_grain.size(), 0);
  for (const TruthGrain& g : grains)
    if (g.outcome == LabelOutcome::matched) out.at(g.best_label) = g.label;
  return out;
}

MatchResult match_labels(const Volume<std::uint32_t>& truth, const Volume<std::uint32_t>& pred) {
  if (truth.shape() != pred.shape()) throw DataError("the truth and the labels differ in shape: score a segmentation of the scan the truth was written with");
  const std::uint32_t* t = truth.data();
  const std::uint32_t* p = pred.data();
  const std::size_t n = truth.size();
  const std::uint32_t nt = n ? *std::max_element(t, t + n) : 0, np = n ? *std::max_element(p, p + n) : 0;
  std::vector<std::uint64_t> size_t_(nt + 1, 0), size_p(np + 1, 0);
  // Overlap counts of (true, predicted) pairs; runs of equal pairs along x are counted at once.
  std::unordered_map<std::uint64_t, std::uint64_t> pairs;
  for (std::size_t i = 0; i < n;) {
    const std::uint32_t a = t[i], b = p[i];
    std::size_t j = i + 1;
    while (j < n && t[j] == a && p[j] == b) ++j;
    size_t_[a] += j - i;
    size_p[b] += j - i;
    if (a != 0 || b != 0) pairs[std::uint64_t{a} << 32 | b] += j - i;
    i = j;
  }
  // Homes: argmax of the overlap, background included (0 = background).
  MatchResult r;
  std::vector<std::uint32_t>& home_of_pred = r.home_grain;
  home_of_pred.assign(np + 1, 0);
  std::vector<std::uint32_t> home_of_truth(nt + 1, 0);
  std::vector<std::uint64_t> best_of_pred(np + 1, 0), best_of_truth(nt + 1, 0);
  r.grains.resize(nt);
  for (const auto& [key, c] : pairs) {
    const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key & 0xFFFFFFFFu);
    if (b != 0 && (c > best_of_pred[b] || (c == best_of_pred[b] && a < home_of_pred[b]))) {
      best_of_pred[b] = c;
      home_of_pred[b] = a;
    }
    if (a != 0 && (c > best_of_truth[a] || (c == best_of_truth[a] && b < home_of_truth[a]))) {
      best_of_truth[a] = c;
      home_of_truth[a] = b;
    }
    if (a != 0 && b != 0) {
      const double iou = static_cast<double>(c) / static_cast<double>(size_t_[a] + size_p[b] - c);
      TruthGrain& g = r.grains[a - 1];
      if (iou > g.best_iou || (iou == g.best_iou && b < g.best_label)) g.best_iou = iou, g.best_label = b;
    }
  }
  std::vector<std::uint32_t> labels_homed(nt + 1, 0), grains_homed(np + 1, 0);
  for (std::uint32_t b = 1; b <= np; ++b) {
    if (size_p[b] == 0) continue;
    ++r.labels;
    if (home_of_pred[b] == 0) ++r.spurious;
    else ++labels_homed[home_of_pred[b]];
  }
  for (std::uint32_t a = 1; a <= nt; ++a)
    if (home_of_truth[a] != 0) ++grains_homed[home_of_truth[a]];
  for (std::uint32_t a = 1; a <= nt; ++a) {
    TruthGrain& g = r.grains[a - 1];
    g.label = a;
    g.voxels = size_t_[a];
    const bool split = labels_homed[a] >= 2;
    const bool merged = home_of_truth[a] != 0 && grains_homed[home_of_truth[a]] >= 2;
    if (g.best_iou >= kIouMatched) g.outcome = LabelOutcome::matched;
    else if (split && merged) g.outcome = LabelOutcome::split_and_merged;
    else if (split) g.outcome = LabelOutcome::split;
    else if (merged) g.outcome = LabelOutcome::merged;
    else if (home_of_truth[a] == 0) g.outcome = LabelOutcome::missed;
    else g.outcome = LabelOutcome::boundary;
  }
  // Labels absent from the truth volume (grains of zero voxels) cannot be scored; there are none
  // in ctsynth scans, whose grains all lie inside the field of view.
  r.grains.erase(std::remove_if(r.grains.begin(), r.grains.end(), [](const TruthGrain& g) { return g.voxels == 0; }),
                 r.grains.end());
  return r;
}

}  // namespace graintwin::validate
