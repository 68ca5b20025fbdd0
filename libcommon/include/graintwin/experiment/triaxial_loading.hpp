#pragma once
// A synthetic series' loading states from mechanics instead of prescribed kinematics (ctsynth
// --loading simulated; docs/ctsynth.md): the packed grains, whose SH surfaces are exact, meshed as
// rigid FDEM grains (mesh/), run through fdemrun's triaxial test of a scene (fdem/), and the
// frames taken at the scans' strains turned back into grain poses, platens, the membrane's
// surface and the pairs' contact forces (synth::LoadedState), and the test's stress-strain curve
// (synth::LoadingCurve). The run's results file is kept in the series folder as simulation.h5
// unless the caller drops it.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/mesh/grain_mesher.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/synth/series.hpp"

namespace graintwin::experiment {

/// What the simulated loading is made from; lengths in metres.
struct TriaxialLoadingParams {
  /// fdemrun scene with a [triaxial] table and a [model] table without a file: its model is the
  /// exact grains'. Its target strain and frame strains are the scans' strains.
  std::filesystem::path scene;
  int surface_subdivisions = 4;   ///< icosphere subdivisions of the exact SH surfaces (2562 directions)
  mesh::SizeTargets size;         ///< element sizes of the grains' rigid meshes
  double platen_friction = 0.0;   ///< Coulomb friction of the end platens
  double membrane_thickness = 0.3e-3;
  bool keep_results = true;       ///< keep the test's results as simulation.h5 in the series folder
};

/// UsageError naming the scene file when it cannot drive the loading of a sample in `container`
/// (a cylinder) with this membrane: unreadable, a table or value fdemrun refuses, no [triaxial]
/// table. Its [model] file, if any, is not read. Cheap: run it before any heavy work.
void check_loading_scene(const std::filesystem::path& scene, const synth::Container& container, double membrane_thickness);

/// UsageError unless a simulated loading can take these grains and states: SH surfaces that are
/// the grains (spheres, ellipsoids, sand; not angular or library grains, whose SH is a fit), a
/// cylinder container, a strain above 0.
void check_loading_inputs(const synth::SeriesParams& series);

/// The grains' body-frame shapes for the mesher: centroid at the origin, the exact SH coefficients,
/// volume, area and inertia-equivalent ellipsoid (its fallback); label i + 1.
std::vector<shape::GrainShape> body_shapes(const synth::GrainSet& grains);

/// The grains meshed from their exact SH surfaces, placed at `packed`, with `container`'s sample
/// cylinder and end platens. `grain_done` after each grain (from the meshing threads).
fdem::Model exact_grains_model(const synth::GrainSet& grains, const std::vector<synth::PackedGrain>& packed,
                               const synth::Container& container, const TriaxialLoadingParams& params,
                               const std::function<void()>& grain_done = {});

/// The membrane's inner surface from its ball centres (B x 3, m) around the vertical axis through
/// `axis_xy`, as its distance from the axis at azimuth theta (rad, atan2(y, x)) and height z: the
/// balls binned in azimuth and height (bins two balls wide and high), each bin's mean distance
/// less the ball radius, bilinear between the bins' centres, periodic in azimuth and constant
/// beyond the end bins in height. A membrane pressed into the hollows between grains is followed.
std::function<double(double theta, double z)> membrane_surface(const std::vector<double>& ball_centres,
                                                               const Eigen::Vector2d& axis_xy, double ball_radius);

/// Where each grain went: grain i packed at `packed[i]`, its model body at `reference_centroid[i]`
/// turned by `reference_rotation[i]` at the start, and at `centroid` (G x 3), `rotation` (G x 4,
/// w x y z) in a frame. The pose of its SH surface: (R R0^-1) applied about the body's centroid.
std::vector<synth::PackedGrain> frame_poses(const std::vector<synth::PackedGrain>& packed,
                                            const std::vector<Eigen::Vector3d>& reference_centroid,
                                            const std::vector<Eigen::Quaterniond>& reference_rotation,
                                            const std::vector<double>& centroid, const std::vector<double>& rotation);

/// The pairs' contact forces of a frame: grain-grain contacts (platen -1) summed per pair, on the
/// higher label.
std::vector<synth::PairForce> pair_forces(const fdem::ResultsFrame& frame);

/// The loading simulation for synth::SeriesParams::simulate.
synth::LoadingSimulation triaxial_loading(const TriaxialLoadingParams& params);

}  // namespace graintwin::experiment
