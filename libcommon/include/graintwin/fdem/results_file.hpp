#pragma once
// `kind=fdem_results` files (docs/formats.md), written by fdemrun while it runs: frames go to disk
// as they are taken (grain centroids, rotations, velocities, volume-averaged stresses; contacts
// with pair, point, normal, force), the time series (energies, platen forces and positions) at the
// end. Checkpoints (`kind=fdem_checkpoint`) hold the solver state and the contact history.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::fdem {

/// One time-series row: the energies at the start of a step and the platen state of that step.
struct SeriesRow {
  std::uint64_t step = 0;
  double time = 0;
  std::uint32_t stage = 0;
  Energies energies;
  std::uint64_t node_contacts = 0;
  std::vector<Eigen::Vector3d> platen_force, platen_position;
};

class ResultsWriter {
 public:
  /// Creates `path` and writes the grain and platen tables, the stages and `parameters_json`.
  ResultsWriter(const std::filesystem::path& path, const Solver& solver, const Scene& scene, const std::string& parameters_json);
  /// Books the step of `dt` just taken (its report holds the energies at its start).
  void add_row(const Solver& solver, const StepReport& report, std::uint32_t stage, double dt);
  /// Writes frame /frames/<k> of the solver's current state.
  void add_frame(const Solver& solver);
  std::size_t frames() const { return frames_; }
  /// Writes the series and the provenance; the file is complete afterwards.
  void finish(const std::vector<std::string>& history);

 private:
  io::H5File file_;
  std::size_t platens_ = 0;
  std::size_t frames_ = 0;
  std::vector<SeriesRow> rows_;
};

/// Frame k of a results file, as stored.
struct ResultsFrame {
  double time = 0;
  std::uint64_t step = 0;
  std::vector<double> centroid, rotation, stress, velocity;  ///< G x 3, G x 4, G x 9, G x 3
  std::vector<std::uint32_t> pair;                           ///< M x 2
  std::vector<std::int32_t> platen;                          ///< M
  std::vector<double> point, normal, force, overlap;         ///< M x 3, M x 3, M x 3, M
};
struct ResultsSeries {
  std::vector<double> time, kinetic, strain, contact_elastic, dissipated, external_work;
  std::vector<std::uint64_t> step;
  std::vector<double> platen_force, platen_position;  ///< R x P x 3
};
/// UsageError naming the file when it is not a results file; DataError when a table is missing.
ResultsSeries read_results_series(const std::filesystem::path& path);
std::size_t results_frame_count(const std::filesystem::path& path);
ResultsFrame read_results_frame(const std::filesystem::path& path, std::size_t frame);

/// Writes a checkpoint (solver state, contact history, `scene_digest`) to `path`.
void write_checkpoint(const std::filesystem::path& path, const Solver& solver, const std::string& scene_digest);
/// Restores a checkpoint into `solver`; UsageError when it was written for another scene.
void read_checkpoint(const std::filesystem::path& path, Solver& solver, const std::string& scene_digest);

}  // namespace graintwin::fdem
