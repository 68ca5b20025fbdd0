#pragma once
// Per-grain properties and spherical-harmonic fits from a label image (docs/methods.md: grain properties, spherical harmonics):
// voxel moments (volume, centroid, inertia-equivalent ellipsoid), an isosurface for the surface
// area, radii along shared directions from the centroid with sub-voxel accuracy, the SH fit with a
// per-grain degree, its errors, and flags for what cannot be trusted.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "graintwin/core/volume.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_fitter.hpp"

namespace graintwin::shape {

/// Bits of GrainShape::flags (stored as /sh/flags).
namespace shape_flag {
inline constexpr std::uint8_t not_star_shaped = 1;    ///< some centroid ray re-enters the grain deeper than the noise floor
inline constexpr std::uint8_t centroid_outside = 2;   ///< the centroid lies outside the grain
inline constexpr std::uint8_t unreliable_fit = 4;     ///< the SH surface misrepresents the grain (see docs)
inline constexpr std::uint8_t touches_edge = 8;       ///< cut by the field of view: shape incomplete
inline constexpr std::uint8_t small = 16;             ///< under 6 voxels across: shape is mostly voxel noise
inline constexpr std::uint8_t tolerance_not_met = 32; ///< even the full degree misses --tol
}  // namespace shape_flag

/// Where the sub-voxel surface comes from.
enum class SurfaceSource {
  labels,  ///< the grain's indicator smoothed with a Gaussian, level 0.5
  grey,    ///< smoothed grey levels between the void and grain levels, level 0.5, bounded by the labels
};

struct MeasureOptions {
  SurfaceSource source = SurfaceSource::labels;
  /// Gaussian sigma (voxels) of the indicator (labels; 0.7 removes the voxel staircase) or of the
  /// grey levels (grey; 0 by default: the labels already bound the surface, and smoothing rounds it).
  double smooth_vox = 0.7;
  double grey_void = 0.0;    ///< grey source: grey level of void (fraction 0)
  double grey_grain = 1.0;   ///< grey source: grey level of grain (fraction 1)
  /// grey source: Gaussian sigma (voxels) of the scanner's point spread (estimate_point_spread).
  /// When > 0 the other grains' labels, blurred by it, are taken off the grey levels, so that a
  /// neighbour's light does not push this grain's surface outward in a packing; 0 leaves them.
  double point_spread_vox = 0.0;
  /// Per-grain degree: the smallest degree whose RMS radial residual is at most tol x equivalent
  /// radius (0: always the fitter's degree).
  double tol = 0.0;
  /// Noise floor of the star-shape test (voxels): a ray's re-entry counts only where the surface it
  /// misses lies at least this far inside the radial surface (depth, see GrainShape::reentry_depth).
  double min_reentry_depth_vox = 0.5;
  /// The fit is unreliable where the radial surface encloses more than this share of the grain's
  /// volume as void (GrainShape::hidden_void_fraction) ...
  double max_hidden_void_fraction = 0.01;
  /// ... or misses a surface deeper than this (voxels; GrainShape::reentry_depth).
  double max_reentry_depth_vox = 1.0;
  /// Undo the inward shift of the iso-surface on curved surfaces (sigma^2 times the mean curvature,
  /// sigma the edge width measured along the rays, GrainShape::edge_sigma), see correct_edge_blur().
  bool correct_blur = true;
};

/// One grain's measurements. Lengths in metres, positions (x, y, z).
struct GrainShape {
  std::uint32_t label = 0;
  std::uint64_t voxels = 0;
  double volume = 0.0;                                   ///< voxel count x voxel volume
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();    ///< mean of voxel centres
  double surface_area = 0.0;                             ///< of the isosurface
  double equivalent_diameter = 0.0;                      ///< (6 V / pi)^(1/3)
  double sphericity = 0.0;                               ///< pi^(1/3) (6 V)^(2/3) / A
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Zero();   ///< a >= b >= c of the ellipsoid with the same inertia
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();    ///< columns: unit directions of a, b, c (right-handed)
  double aspect_ratio = 1.0;                             ///< a / c
  double elongation = 1.0;                               ///< b / a
  double flatness = 1.0;                                 ///< c / b
  int sh_degree = 0;                                     ///< degree kept for this grain
  Eigen::VectorXd coeffs;                                ///< fitter degree; zero above sh_degree
  Eigen::VectorXd invariants;                            ///< ||R_n||, n = 0..fitter degree
  double rms_error = 0.0;                                ///< RMS radial residual / equivalent radius
  double max_error = 0.0;                                ///< largest |radial residual| / equivalent radius
  double volume_error = 0.0;                             ///< (V_sh - V) / V
  double multi_exit_fraction = 0.0;                      ///< share of rays with a re-entry above the noise floor
  /// Void the radial surface (last exits) encloses, between a ray's first exit and its last re-entry,
  /// over the grain's volume, counting the rays above the noise floor.
  double hidden_void_fraction = 0.0;
  /// Largest distance (m) between a missed surface and the radial surface over the rays: (last exit -
  /// first exit) times |cos| of the angle between the ray and the surface normal at the last exit.
  double reentry_depth = 0.0;
  /// Edge width (m): Gaussian sigma of the grey (or smoothed-label) profile across the surface as
  /// read through the trilinear field (which adds 1/6 voxel^2), median over the rays; 0 when
  /// unmeasured. The blur correction uses it.
  double edge_sigma = 0.0;
  std::uint8_t flags = 0;
};

/// Sets g's size and form from the descriptors of its exact surface: volume, surface area, diameter,
/// sphericity, inertia ellipsoid and its aspect, elongation and flatness.
void set_form(GrainShape& g, const ShapeStats& stats);

/// Measures the grain `label` whose voxels lie in the half-open box `bbox` (z0, y0, x0, z1, y1, x1)
/// of `labels`. `grey` (same shape) is required for SurfaceSource::grey, else ignored (may be
/// null). Thread-safe: call it for many grains in parallel. DataError if the box holds no voxel of
/// the label.
template <class T>
GrainShape measure_grain(const Volume<std::uint32_t>& labels, const Volume<T>* grey, std::uint32_t label,
                         const std::array<std::size_t, 6>& bbox, const ShFitter& fitter, const MeasureOptions& options);

/// The first-order inverse of the edge blur for a radial SH surface of equivalent radius `radius`:
/// a surface blurred by a Gaussian of `sigma` has its 0.5 level moved inward by sigma^2 H (H the
/// mean curvature), which for r = R + sum c_nm Y_nm (small c) is c_00 / sqrt(4 pi) -> - sigma^2 / R
/// and c_nm -> c_nm (1 - sigma^2 (n (n + 1) - 2) / (2 R^2)). Returns the coefficients with that
/// shift undone; the gain of a degree is capped at 1.5 (detail that much below the blur is lost,
/// amplifying it would amplify noise). Degree-1 terms (translation) are unchanged.
Eigen::VectorXd correct_edge_blur(const Eigen::VectorXd& coeffs, int degree, double sigma, double radius);

/// measure_grain for every (label, bbox), in parallel over grains (OpenMP, dynamic schedule), in
/// the given order; `progress` (may be empty) receives the fraction done from the calling thread.
template <class T>
std::vector<GrainShape> measure_grains(const Volume<std::uint32_t>& labels, const Volume<T>* grey,
                                       const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>& grains,
                                       const ShFitter& fitter, const MeasureOptions& options,
                                       const std::function<void(double)>& progress = {});

/// The scanner's point spread (Gaussian sigma, voxels) seen in a segmented scan: the grey-source
/// edge width of up to `sample` grains spread over the list (measured without neighbour
/// subtraction), median, less the spread that the voxel's box (1/12 voxel^2) and the trilinear
/// reading of the edge (1/6) add. `options` as for measure_grains with the grey source. 0 if no
/// edge could be read.
template <class T>
double estimate_point_spread(const Volume<std::uint32_t>& labels, const Volume<T>& grey,
                             const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>& grains,
                             const ShFitter& fitter, MeasureOptions options, std::size_t sample = 64);

/// Typical grey levels of void and of grain in a segmented scan: the medians over voxels whose six
/// neighbours share their label (background for void, one grain for grain), so partial-volume
/// voxels at surfaces do not bias them. Sampled on a regular stride (at most ~4 million voxels per
/// class). DataError if either class has no such voxel or the two levels coincide.
struct GreyLevels {
  double void_level = 0.0;
  double grain_level = 0.0;
};
template <class T>
GreyLevels grey_levels(const Volume<std::uint32_t>& labels, const Volume<T>& grey);

/// Percent passing by volume against diameter: diameters sorted ascending, percent[i] = 100 x the
/// volume of grains with d <= diameters[i] over the total; d50 interpolated linearly in percent.
struct SizeDistribution {
  std::vector<double> diameter;
  std::vector<double> percent_passing;
  double d50 = 0.0;
};
SizeDistribution size_distribution(const std::vector<double>& diameters, const std::vector<double>& volumes);
/// The same of the grains' equivalent diameters and volumes.
SizeDistribution size_distribution(const std::vector<GrainShape>& grains);

}  // namespace graintwin::shape
