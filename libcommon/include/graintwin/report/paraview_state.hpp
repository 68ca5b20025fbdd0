#pragma once
// A ParaView state file of a pipeline run (docs/report.md, "The run in ParaView"): two views side by
// side, the scans (the grains' surfaces of every scan, the tracks) and the FDEM twin (its frames,
// the membrane's balls, the force chains) as the pipeline's stages wrote them for ParaView, with
// colours chosen here and a camera on the sample. The paths are relative to the state's folder, so
// the run folder can be moved: ParaView finds the files when the state is loaded with the run
// folder as its data directory. The membrane has no VTK file of fdemrun's; write_membrane_frames
// writes one per frame from the results.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/report/run_data.hpp"

namespace graintwin::report {

namespace fs = std::filesystem;

/// The names Makefile.pipeline gives the stages' files for ParaView inside a run (and a scan) folder.
namespace paraview_layout {
inline constexpr const char* grains = "grains.vtp";                       ///< per scan: labels2shapes --surfaces
inline constexpr const char* tracks = "tracks.vtp";                       ///< shapes2tracks --vtk
inline constexpr const char* frames = "simulation_frames/frames.pvd";     ///< fdemrun --vtk
inline constexpr const char* chains = "force_chains/chains.pvd";          ///< fdem2forces --chains
}  // namespace paraview_layout

/// One data set the state opens, and how it is drawn.
struct StateSource {
  std::string name;         ///< in ParaView's pipeline browser
  std::string file;         ///< relative to the state's folder, '/' separated
  std::string reader;       ///< ParaView's reader: "XMLPolyDataReader" (.vtp) or "PVDReader" (.pvd, a time series)
  int view = 0;             ///< 0: the scans' view (left), 1: the twin's (right)
  bool visible = true;
  std::string representation = "Surface";  ///< "Surface", "Points", "Point Gaussian"
  std::array<double, 3> colour{0.8, 0.8, 0.8};
  double opacity = 1.0;
  double point_size = 2.0;       ///< pixels ("Points")
  double line_width = 1.0;       ///< pixels (lines)
  double gaussian_radius = 0.0;  ///< m ("Point Gaussian": spheres of this radius)
  std::string colour_by;         ///< a cell array painted on a viridis scale over colour_range; empty: `colour`
  std::array<double, 2> colour_range{0.0, 1.0};
};

/// The state's XML: every source with its reader, representation and view, the two views side by
/// side, both cameras looking along +y from 20 degrees above at the box `bounds` (x0, x1, y0, y1,
/// z0, z1; m), and the time keeper following every time series so ParaView plays the frames.
std::string paraview_state_xml(const std::vector<StateSource>& sources, const std::array<double, 6>& bounds);

/// The membrane balls of every frame of a results file as `folder`/membrane_<k>.vtp (points) and
/// `folder`/membrane.pvd (by the frames' times); `folder` is created. False, writing nothing, when
/// no frame holds a membrane.
bool write_membrane_frames(const fs::path& simulation, const fs::path& folder);

/// The sources of a run for its state: each scan's grains (the reference scan's shown, the others
/// hidden: they overlap), the tracks, the twin's frames, the membrane (`membrane_pvd`, relative to
/// `state_folder`, empty without one; balls of `ball_radius`), the force chains: those of
/// paraview_layout present in `run_dir`, with paths relative to `state_folder`.
std::vector<StateSource> run_state_sources(const fs::path& run_dir, const RunFiles& files, const fs::path& state_folder,
                                           const std::string& membrane_pvd, double ball_radius);

/// Writes the state of the run to `state` (its final path `final_state`, whose folder the paths
/// are relative to) and the membrane's frames to `membrane` (named `final_membrane` in the state).
/// Returns the sources written.
std::vector<StateSource> write_paraview_state(const fs::path& run_dir, const RunFiles& files, const fs::path& state,
                                              const fs::path& final_state, const fs::path& membrane, const fs::path& final_membrane);

}  // namespace graintwin::report
