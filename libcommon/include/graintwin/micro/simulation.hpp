#pragma once
// Simulation frames (kind=fdem_results, written by fdemrun) as micro-mechanics states: every grain
// of the simulation is present in every frame, volumes come from /grains/volume, coordination
// numbers from each frame's grain-grain contacts (exact, unlike the CT side's distance criterion);
// and each frame's grain-grain contacts with their normal forces, for fdem2forces; the roses of
// their branch vectors, for the report.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <unordered_map>
#include <vector>

#include "graintwin/contacts/fabric.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/micro/analysis.hpp"

namespace graintwin::micro {

/// The simulation's grains: labels and volumes (m^3) in the results file's row order, the label ->
/// row map, and their size distribution (volume-equivalent diameters, by volume).
struct SimulationGrains {
  std::vector<std::uint32_t> label;
  std::vector<double> volume;
  std::unordered_map<std::uint32_t, std::size_t> row;
  shape::SizeDistribution psd;
};
/// UsageError when `path` is not kind=fdem_results; DataError when its grain table is empty,
/// uneven, repeats a label or holds a non-positive volume.
SimulationGrains read_simulation_grains(const std::filesystem::path& path);

/// Grain-grain contacts of one frame (platen contacts left out), as grain rows.
struct FrameContacts {
  std::vector<std::pair<std::size_t, std::size_t>> pair;  ///< rows into SimulationGrains
  std::vector<Eigen::Vector3d> normal;                    ///< unit, first -> second
  std::vector<double> normal_force;                       ///< N, force on the second along the normal (> 0 pushes apart)
  std::size_t platen_contacts = 0;                        ///< grain-platen contacts left out
};
/// DataError naming `path` and the frame when the frame's tables disagree in size or name an
/// unknown label.
FrameContacts frame_contacts(const fdem::ResultsFrame& frame, const SimulationGrains& grains, const std::filesystem::path& path,
                             std::size_t frame_index);

/// Grain centroids of a frame (G), m; DataError when the frame does not hold one per grain.
std::vector<Eigen::Vector3d> frame_centroids(const fdem::ResultsFrame& frame, const SimulationGrains& grains,
                                             const std::filesystem::path& path, std::size_t frame_index);

/// Every frame of `path` as a state of a series over the simulation's grains: positions,
/// volumes, d50 and PSD (the same in every frame) and coordination numbers from the frame's
/// grain-grain contacts. `times` (may be null) gets each frame's time (s). DataError when the
/// file has no frames.
SeriesStates simulation_states(const std::filesystem::path& path, const SimulationGrains& grains, std::vector<double>* times);

/// Roses of the branch vectors (centroid to centroid of the grain-grain contacts) of the frames
/// `frames` of `path`, with `theta_bins` x `phi_bins` bins (contacts::rose).
std::vector<contacts::Rose> simulation_branch_roses(const std::filesystem::path& path, const std::vector<std::size_t>& frames,
                                                    int theta_bins, int phi_bins);

}  // namespace graintwin::micro
