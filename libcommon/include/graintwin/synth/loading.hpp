#pragma once
// Prescribed kinematics of a cylindrical sample under triaxial loading, for synthetic scan series:
// axial compression between platens, barrel-shaped lateral bulging, one inclined or two crossing
// (X) shear bands with a smooth slip profile, nonaffine random motion concentrated in the bands,
// and per-grain rotations that grow with the local shear. States are cumulative: state k is
// reached from state k-1 by the strain increment, so nonaffine motion and rotations random-walk.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::synth {

enum class ShearBand { none, single, crossed };
/// ctsynth's --band names.
inline constexpr std::array<EnumName<ShearBand>, 3> kShearBandNames{
    {{ShearBand::none, "none"}, {ShearBand::single, "single"}, {ShearBand::crossed, "crossed"}}};

/// Where a series' states come from: made-up kinematics, or a simulated triaxial test.
enum class LoadingKind { prescribed, simulated };
/// ctsynth's --loading names, also the ground truth's and series.json's `loading`.
inline constexpr std::array<EnumName<LoadingKind>, 2> kLoadingKindNames{
    {{LoadingKind::prescribed, "prescribed"}, {LoadingKind::simulated, "simulated"}}};

struct LoadingParams {
  double centre_x = 0.0, centre_y = 0.0;  ///< sample axis (m)
  double height = 0.0;                    ///< initial sample height H0 (m); base at z = 0
  double radius = 0.0;                    ///< initial sample radius (m)
  double bulge = 0.5;                     ///< lateral strain at mid-height per unit axial strain, averaged
                                          ///< over the height (0.5 keeps the volume, more dilates)
  ShearBand band = ShearBand::single;
  double band_angle_deg = 60.0;           ///< band inclination from the horizontal
  double band_azimuth_deg = 0.0;          ///< direction of the dip in the x-y plane
  double band_width = 0.0;                ///< band thickness (m), about 10 d50
  double band_slip = 0.5;                 ///< slip across a band per unit axial strain, in units of H0
  double nonaffine = 0.15;                ///< std of random grain motion in a band, per unit band slip
  /// Correlation length (m) of that random motion: 0 draws it independently per grain; a length
  /// makes it a smooth random field over that distance, so neighbours move together (their relative
  /// motion, which overlaps them, is a fraction of each one's) while the std per grain stays.
  double nonaffine_correlation = 0.0;
  double rotation_per_shear = 0.5;        ///< grain rotation (rad) per unit local shear strain
  double rotation_noise_deg = 0.2;        ///< random rotation per state outside bands (deg, std)
  std::uint64_t seed = 1;
};

/// Displacement (m) of the affine part plus the band slip at reference position x for axial
/// strain eps (compression positive, nominal: H = H0 (1 - eps)).
Eigen::Vector3d smooth_displacement(const LoadingParams& p, const Eigen::Vector3d& x, double eps);

/// Local shear strain of the smooth field at x for axial strain eps (for rotations and docs).
double local_shear(const LoadingParams& p, const Eigen::Vector3d& x, double eps);

/// Poses of all grains at each strain of `strains` (first entry usually 0), from their reference
/// poses. Element [k][i] is grain i at state k. Positions are centroids.
std::vector<std::vector<PackedGrain>> loading_states(const LoadingParams& p, const std::vector<PackedGrain>& reference,
                                                     const std::vector<double>& strains);

/// Throws UsageError unless a nonaffine correlation length (m) is 0 (independent grains) or long
/// enough for its random lattice over a sample of `extent` (m, per axis) to stay a modest size.
/// loading_states checks it over the grains' centres; callers check it over their container
/// before any heavy work.
void check_nonaffine_correlation(double length, const Eigen::Vector3d& extent);

/// Inner radius of the (bulged) membrane at height z of the deformed sample for strain eps.
double sample_radius_at(const LoadingParams& p, double z_deformed, double eps);

}  // namespace graintwin::synth
