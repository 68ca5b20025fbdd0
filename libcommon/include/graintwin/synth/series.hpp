#pragma once
// A synthetic CT scan series, ctsynth's whole stage: the grains (drawn from a PSD, or from a shape
// library read from a segmented scan), their dense packing, the loading states, and per state a
// rendered scan and its exact ground truth, written to one folder (docs/ctsynth.md).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/synth/grains.hpp"
#include "graintwin/synth/loading.hpp"
#include "graintwin/synth/packing.hpp"
#include "graintwin/synth/psd.hpp"
#include "graintwin/synth/render.hpp"

namespace graintwin::synth {

/// Everything a series is made from; lengths in metres. The tool fills it from its options.
struct SeriesParams {
  std::uint64_t seed = 1;
  GrainSetParams grains;          ///< shape family and its parameters; its voxel_size and seed are set from here
  Psd psd;                        ///< grain sizes (not used with a shape library)
  std::filesystem::path library_shapes, library_labels;  ///< GrainShape::library: the kind=shapes and kind=labels files
  std::vector<int> pack_degrees;  ///< sand and angular grains: SH degrees of the packing stages (pack_in_stages)
  double solid_fraction = 0.55;   ///< grain volume / container volume
  PackingParams packing;          ///< its seed is set from here
  Container container;
  double voxel_size = 27.5e-6;
  double margin = 0.0;            ///< air around the sample and membrane
  double membrane_thickness = 0.0;  ///< cylinder only; 0 = none
  RenderParams render;
  ScannerParams scanner;          ///< grey levels and artifacts; the axis, field radius and seed are set per scan
  LoadingParams loading;          ///< the kinematics; axis, height, radius, seed and a band width of 0 (= 10 d50) are set here
  std::vector<double> strains{0.0};  ///< nominal axial strain of each scan
  double contact_search = 0.0;    ///< truth near-contacts closer than this; 0 = 2 voxels
};

/// What the tool reports and keeps of a finished series (series.json holds it too).
struct SeriesSummary {
  std::size_t grains = 0;
  std::size_t non_star_grains = 0;  ///< grains whose radial description misses > 1 % of the volume or > 1 voxel
  double packed_solid_fraction = 0.0;
};

/// Makes the series in the existing folder `dir`: scan_NNN.h5 (kind=volume) and truth_NNN.h5
/// (kind=ground_truth) per strain, and series.json. Checks the grey levels, the blur kernel and
/// the memory the series needs (UsageError naming the options to change) before the heavy work;
/// reads the shape library first when there is one. `history` goes into every file; `progress`
/// makes the progress callback of a named step.
SeriesSummary make_series(const SeriesParams& params, const std::filesystem::path& dir,
                          const std::vector<std::string>& history,
                          const std::function<std::function<void(double)>(const std::string&)>& progress);

}  // namespace graintwin::synth
