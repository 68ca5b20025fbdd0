#pragma once
// A synthetic CT scan series, ctsynth's whole stage: the grains (drawn from a PSD, or from a shape
// library read from a segmented scan), their dense packing, the loading states, and per state a
// rendered scan and its exact ground truth, written to one folder (docs/ctsynth.md).
#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "graintwin/synth/grains.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/synth/loading.hpp"
#include "graintwin/synth/packing.hpp"
#include "graintwin/synth/psd.hpp"
#include "graintwin/synth/render.hpp"

namespace graintwin::synth {

/// A contact force of a simulated state between grains `low` < `high` (labels: index + 1): the sum
/// over the pair's contact points of the force on `high`, N.
struct PairForce {
  std::uint32_t low = 0, high = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
};

/// One loaded state of a series: where every grain is and what bounds the sample.
struct LoadedState {
  double axial_strain = 0.0;         ///< prescribed: nominal; simulated: log strain ln(H0 / H) from the start of shearing
  std::vector<PackedGrain> poses;    ///< every grain, in the grains' order
  double base_z = 0.0, top_z = 0.0;  ///< m, the platens
  /// Inner radius (m) of the membrane at azimuth theta (rad, about the sample's axis) and height z:
  /// the sample's lateral surface.
  std::function<double(double theta, double z)> membrane_inner_radius;
  double contact_tolerance = 0.0;    ///< m: pairs overlapping at most this much touch
  double max_overlap = 0.0;          ///< m, largest overlap of two grains
  std::size_t relax_sweeps = 0;      ///< prescribed states: sweeps of the overlap relaxation
  /// Simulated states: the pairs' contact forces, sigma_1 / sigma_3 and eps_v = ln(V0 / V) (NaN otherwise).
  std::vector<PairForce> forces;
  bool simulated = false;
  double stress_ratio = std::numeric_limits<double>::quiet_NaN();
  double volumetric_strain = std::numeric_limits<double>::quiet_NaN();
};

/// What a simulated test gives a series: its state at each scan's strain and its whole curve.
struct SimulatedLoading {
  std::vector<LoadedState> states;
  LoadingCurve curve;
};

/// The states of a series at the given strains, from the grains (`tables`, in order) packed at
/// `packed` in `container`; `dir` is the series folder (a simulation may write its results there),
/// `history` goes into any file it writes, `progress` makes the progress callback of a named step.
using LoadingSimulation = std::function<SimulatedLoading(
    const GrainSet& grains, const std::vector<PackedGrain>& packed, const Container& container,
    const std::vector<double>& strains, const std::filesystem::path& dir, const std::vector<std::string>& history,
    const std::function<std::function<void(double)>(const std::string&)>& progress)>;

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
  std::vector<double> strains{0.0};  ///< axial strain of each scan (nominal, or log with `simulate`)
  /// Empty: the states are `loading`'s prescribed kinematics, their overlaps relaxed. Else the
  /// states this simulation gives (a mechanical test of the packed grains).
  LoadingSimulation simulate;
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
