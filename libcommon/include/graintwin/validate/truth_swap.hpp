#pragma once
// truthswap's stage (docs/truthswap.md): a stage's output with the ground truth of a ctsynth scan
// put in its place, so that the stages after it run on exact input and the error each stage adds
// to the twin can be told apart (bench/twin_fidelity_bench.py swaps one stage at a time).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/synth/ground_truth.hpp"

namespace graintwin::validate {

/// A labels file whose label image is the truth's (true grain i is label i + 1) with its grain
/// table, in place of `measured` (ct2labels' file of the same scan): the sample cylinder is
/// `measured`'s (finding it is part of ct2labels' measurement, not of the labels), the void ratio is
/// the truth's in that cylinder, and the segmentation parameters record the swap. DataError when
/// the two images differ in shape.
segment::LabelsFile labels_from_truth(const synth::GroundTruth& truth, const segment::LabelsFile& measured);

/// What a shapes swap takes from the truth.
struct ShapeSwapOptions {
  /// Also each grain's centroid (the truth's pose) instead of the measured one (the mean of its
  /// voxel centres).
  bool positions = false;
};

struct ShapeSwap {
  shape::ShapesFile file;
  std::size_t swapped = 0;  ///< grains given their true shape
  std::size_t kept = 0;     ///< grains not faithfully segmented (IoU < 0.8), left as measured
};

/// `measured` (labels2shapes' file, measured from `labels`) with every grain that `labels`
/// reproduces faithfully (label_match: IoU >= 0.8 with one true grain) given that grain's exact SH
/// surface: the truth's world-frame coefficients about its centroid, their invariants, and the
/// volume, surface area, inertia ellipsoid, diameter and sphericity measured on that surface, with
/// no fit error and no flag. Its label and voxel count stay. The file's SH degree becomes the larger
/// of the two (coefficients above a grain's degree are zero). DataError when `labels` and the
/// truth image differ in shape.
ShapeSwap shapes_from_truth(const synth::GroundTruth& truth, const shape::ShapesFile& measured,
                            const Volume<std::uint32_t>& labels, const ShapeSwapOptions& options);

/// truthswap's files: the truth of one scan, a stage's output of that scan (kind=labels or
/// kind=shapes) and, for a shapes file, the labels file it was measured from.
struct TruthSwapFiles {
  std::filesystem::path truth, input, labels;
};

/// What a swap did: the kind of the file written and how many grains took the truth.
struct TruthSwapSummary {
  std::string kind;
  std::size_t grains = 0, swapped = 0, kept = 0;
};

/// UsageError in one sentence naming the file and the fix when the request cannot be made: the
/// input is neither a labels nor a shapes file, a shapes file comes without its labels file,
/// positions are asked of a labels file, the truth is not a ground truth. Reads only the files'
/// kinds: run it before the heavy work.
void check_truth_swap(const TruthSwapFiles& files, const ShapeSwapOptions& options);

/// Reads the files, swaps (labels_from_truth or shapes_from_truth) and writes the result to
/// `output` with `history`.
TruthSwapSummary swap_truth(const TruthSwapFiles& files, const ShapeSwapOptions& options,
                            const std::filesystem::path& output, const std::vector<std::string>& history);

}  // namespace graintwin::validate
