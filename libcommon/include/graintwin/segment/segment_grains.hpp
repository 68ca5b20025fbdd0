#pragma once
// The whole ct2labels chain as one function (docs/methods.md, segmentation): denoise -> threshold -> hole
// filling / opening -> sample region and void ratio -> EDT -> markers -> watershed of -EDT ->
// fragments -> edge grains -> sequential labels -> grain table. The tool and the benchmarks call
// this, so what is measured is what users run.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/connectivity.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/markers.hpp"
#include "graintwin/segment/sample_region.hpp"

namespace graintwin::segment {

enum class Denoise { none, median, gaussian };
enum class MarkerMethod { h_maxima, peaks };
/// Where the void ratio is measured: the sample cylinder found in the mask, a given cylinder, or
/// the whole volume (a crop from inside a sample).
enum class RegionMode { auto_cylinder, given_cylinder, whole_volume };

struct SegmentOptions {
  /// Measured (ct2labels_accuracy_bench, sigma 0.3-0.7 over 8-24 voxels per d50 and 2-10 % noise):
  /// 0.4 voxel keeps the narrow gaps between grains that the 3x3x3 median fills.
  Denoise denoise = Denoise::gaussian;
  double gaussian_sigma_vox = 0.4;
  std::optional<double> threshold;       ///< grey level; solid is strictly above. Empty: Otsu.
  bool fill_holes = true;
  double open_radius_vox = 0.0;          ///< morphological opening of the mask; 0 = none
  MarkerMethod markers = MarkerMethod::h_maxima;
  std::optional<double> h_vox;           ///< h-maxima depth; empty: propose_h chooses it
  std::optional<double> min_distance_vox;///< peak spacing; empty: the reference grain radius
  double expected_d50_m = 0.0;           ///< bounds the automatic choices; 0 = estimate from the EDT
  Connectivity connectivity = Connectivity::corners;
  std::optional<double> min_volume_vox;  ///< fragment size limit; empty: 5 % of a reference grain
  FragmentPolicy fragments = FragmentPolicy::merge;
  bool remove_edge_grains = false;
  RegionMode region_mode = RegionMode::auto_cylinder;
  Cylinder region;                       ///< used with RegionMode::given_cylinder
  /// Called with the name of each step as it starts (for progress and logs).
  std::function<void(const std::string& step)> on_step;
};

/// Everything a run decided and measured, for the output file and the log.
struct SegmentResult {
  Volume<std::uint32_t> labels;          ///< 0 = background, 1..N numbered in raster order of first voxel
  std::vector<GrainRecord> grains;       ///< one per label, in label order
  double threshold = 0.0;                ///< grey level used
  bool threshold_from_otsu = false;
  double solid_fraction = 0.0;           ///< of the whole volume, after hole filling / opening
  MarkerMethod marker_method = MarkerMethod::h_maxima;
  double marker_parameter_vox = 0.0;     ///< h or the minimum peak distance actually used
  bool marker_parameter_automatic = false;
  std::optional<HProposal> h_proposal;   ///< when propose_h ran
  std::size_t markers = 0;
  double reference_radius_m = 0.0;       ///< grain radius behind the automatic choices
  double min_volume_vox = 0.0;           ///< fragment limit used
  FragmentReport fragments;
  std::size_t edge_grains_removed = 0;
  RegionMode region_mode = RegionMode::auto_cylinder;
  Cylinder region;                       ///< where void_ratio was measured (unbounded for whole_volume)
  VoidRatio void_ratio;
};

/// Segments grey-level CT volume `grey` (consumed: it is released as soon as the mask exists, which
/// keeps the peak near 12 bytes per voxel for uint16 input). T: uint8, uint16 or float.
/// Throws DataError with a one-sentence reason for volumes that cannot be segmented (empty,
/// constant, non-finite values, no solid, no void, no grain left) and UsageError for bad options.
template <class T>
SegmentResult segment_grains(Volume<T> grey, const SegmentOptions& options);

/// Checks option values before any heavy work (UsageError naming the option).
void validate(const SegmentOptions& options);

/// The options' names, as ct2labels takes them and its labels files record them; the parse
/// functions refuse an unknown name (UsageError naming the option and listing the known names).
const char* to_string(Denoise d);
const char* to_string(MarkerMethod m);
const char* to_string(FragmentPolicy f);
const char* to_string(RegionMode r);
Denoise parse_denoise(const std::string& name);                 ///< --denoise: none, median or gaussian
MarkerMethod parse_marker_method(const std::string& name);      ///< --markers: h-maxima or peaks
FragmentPolicy parse_fragment_policy(const std::string& name);  ///< --fragments: merge or remove
RegionMode parse_region_mode(const std::string& name);          ///< --region: auto, volume or cylinder

}  // namespace graintwin::segment
