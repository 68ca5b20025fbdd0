#pragma once
// What the report reads from a pipeline run (Makefile.pipeline's layout under runs/<series>/):
// the files of each scan, the series' tracks and micro-mechanics, the FDEM model, and the
// simulation side (results, forces, micro-mechanics of the frames). Locating and checking them is
// cheap (root attributes only) and happens before anything is read; the readers then load only
// the tables the charts need, never label images or meshes (the sections, report/sections.hpp,
// read the model's surfaces and have the chart script read one slice of a label image).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/run_layout.hpp"
#include "graintwin/micro/distributions.hpp"
#include "graintwin/micro/forces.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/shape/grain_measure.hpp"

namespace graintwin::report {

namespace fs = std::filesystem;

/// The run's files; an empty path is a file the run does not have.
struct RunFiles {
  std::vector<std::string> scan_names;  ///< e.g. scan_000, in order
  std::vector<fs::path> labels, contacts, shapes;  ///< one entry per scan (empty = absent)
  /// The scans themselves (kind=volume, the segment stage's inputs): grey under the labels of the
  /// sections. Not in the run directory: named by --volumes, one per scan, or none.
  std::vector<fs::path> volumes;
  fs::path tracks, micro, model;
  fs::path simulation, forces, simulation_micro;
  fs::path scan_strains;  ///< JSON with the scans' applied axial strains (ctsynth's series.json)
  fs::path validation;    ///< validate's error budget against the series' ground truth (validation.json)
};

/// The file names of Makefile.pipeline inside a run directory.
namespace layout = io::run_layout;

/// UsageError "WHAT PATH does not exist; check the path" (or "is a folder, not a file; FIX", or "is
/// not a regular file ...; FIX") unless `path` is a regular file or a link to one. `what` names the
/// path for the user: an option ("--python") or a role ("the run's file").
void require_file(const fs::path& path, const std::string& what, const std::string& fix = "name the file itself");
/// The same for a folder ("is a file, not a folder"); `fix` ends the message when the path exists
/// but is not a folder.
void require_folder(const fs::path& path, const std::string& what, const std::string& fix);

/// Fills what `given` leaves empty from `run_dir`'s layout: scans are the scan_* folders holding
/// a labels file (unless `given.labels` lists them), the per-scan and series files those that
/// exist. Files named in `given` must be files. UsageError in one sentence naming the path and the
/// fix: no run directory (or a file in its place), no scans, a named file missing or a folder, a
/// layout name that is not a file (a folder called tracks.h5), per-scan lists of the wrong length.
RunFiles locate_run_files(const fs::path& run_dir, const RunFiles& given);

/// Opens every file of `files` and checks its kind (UsageError naming the file and the stage that
/// writes it; validation.json is read whole by validate's reader). Returns each file's provenance
/// history, keyed by path, in reading order.
std::vector<std::pair<std::string, std::vector<std::string>>> check_run_files(const RunFiles& files);

/// One scan: its void ratio (labels), size distribution (shapes), coordination numbers and roses
/// (contacts). NaN / empty where its file is absent.
struct ScanData {
  std::string name;
  double void_ratio = 0.0;
  std::size_t grains = 0, contacts = 0;
  shape::SizeDistribution psd;
  std::vector<std::uint64_t> coordination;  ///< grains with Z = index
  double coordination_mean = 0.0;
  micro::ForceRose rose_normal, rose_branch;  ///< counts only (no mean_force)
};

/// The parts of kind=micro and kind=forces files the charts show, as their modules read them.
using MicroState = micro::MicroStateTables;
using MicroIncrement = micro::MicroIncrementTables;
using MicroData = micro::MicroTables;
using ForcesFrame = micro::ForcesFrameTables;
using ForcesWindow = micro::ForcesWindowTables;
using ForcesData = micro::ForcesTables;

/// Everything of the experiment side.
struct ExperimentData {
  std::vector<ScanData> scans;
  std::optional<MicroData> micro;
  std::size_t tracks = 0;  ///< tracks in the tracks file (0 without one)
  /// Per scan, from the affine map of the tracked centroids from scan 0 (micro::tracked_strains;
  /// empty without tracks).
  std::vector<double> tracked_axial_strain, tracked_volumetric_strain;
  /// Per scan eps_v = ln((1 + e_0) / (1 + e)) from the labels' void ratios (constant solid volume).
  std::vector<double> void_ratio_volumetric_strain;
  std::vector<double> applied_axial_strain;  ///< per scan, from RunFiles::scan_strains (else empty)
};
ExperimentData read_experiment(const RunFiles& files);

/// The simulation side; the branch roses of up to `frames_shown` frames (pick_evenly) with
/// `theta_bins` polar bands.
struct SimulationData {
  bool present = false;  ///< a results file exists
  std::size_t grains = 0, frames = 0;
  fdem::TriaxialSeries series;
  shape::SizeDistribution psd;  ///< of the simulated grains (volume-equivalent diameters)
  std::optional<MicroData> micro;
  std::optional<ForcesData> forces;
  std::vector<std::size_t> rose_frames;            ///< frames of the branch roses
  std::vector<micro::ForceRose> branch_roses;
};
SimulationData read_simulation(const RunFiles& files, std::size_t frames_shown, int theta_bins);

}  // namespace graintwin::report
