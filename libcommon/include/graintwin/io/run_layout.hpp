#pragma once
// The file names of Makefile.pipeline inside a run directory (runs/<series>/), for the stages that
// read a whole run: report and validate.
namespace graintwin::io::run_layout {
inline constexpr const char* scan_prefix = "scan_";  ///< scan folders: scan_000, scan_001, ...
inline constexpr const char* labels = "labels.h5";
inline constexpr const char* contacts = "contacts.h5";
inline constexpr const char* shapes = "shapes.h5";
inline constexpr const char* tracks = "tracks.h5";
inline constexpr const char* micro = "micro.h5";
inline constexpr const char* model = "model.h5";
inline constexpr const char* simulation = "simulation.h5";
inline constexpr const char* forces = "forces.h5";
inline constexpr const char* simulation_micro = "simulation_micro.h5";
inline constexpr const char* validation = "validation.json";  ///< validate's error budget against the truth
/// In the series folder (sample_volumes/<series>/): ctsynth's truth beside scan_NNN.h5.
inline constexpr const char* truth_prefix = "truth_";
}  // namespace graintwin::io::run_layout
