#pragma once
// The sample region of a triaxial scan: the cylinder (axis along z) that holds the grains, found
// from the solid mask or given, and the void ratio e = V_void / V_solid inside it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "graintwin/core/volume.hpp"

namespace graintwin::segment {

/// A cylinder with its axis along z. Lengths in metres; x and y are physical coordinates.
struct Cylinder {
  double centre_x = 0.0, centre_y = 0.0;
  double radius = 0.0;
  /// Axial extent (default: unbounded, i.e. the whole height of the volume).
  double z_min = -std::numeric_limits<double>::infinity(), z_max = std::numeric_limits<double>::infinity();
  /// True if the centre of voxel (z, y, x) of `v` lies inside.
  template <class T>
  bool contains(const Volume<T>& v, std::size_t z, std::size_t y, std::size_t x) const {
    const Vec3 p = v.position_xyz(static_cast<double>(z), static_cast<double>(y), static_cast<double>(x));
    const double dx = p[0] - centre_x, dy = p[1] - centre_y;
    return p[2] >= z_min && p[2] <= z_max && dx * dx + dy * dy <= radius * radius;
  }
  /// The x index range [first, last) of row (z, y) of `v` whose voxel centres lie inside (the same
  /// voxels as `contains`, up to rounding exactly on the surface); first == last if none.
  template <class T>
  std::pair<std::size_t, std::size_t> row_span(const Volume<T>& v, std::size_t z, std::size_t y) const {
    const Vec3 p = v.position_xyz(static_cast<double>(z), static_cast<double>(y), 0.0);
    const double dy = p[1] - centre_y, half2 = radius * radius - dy * dy;
    if (!(p[2] >= z_min && p[2] <= z_max && half2 >= 0.0)) return {0, 0};
    if (std::isinf(half2)) return {0, v.nx()};
    const double half = std::sqrt(half2), dx = v.voxel_size()[2];
    const double lo = std::ceil((centre_x - half - p[0]) / dx), hi = std::floor((centre_x + half - p[0]) / dx) + 1.0;
    const double nx = static_cast<double>(v.nx());
    const auto first = static_cast<std::size_t>(std::clamp(lo, 0.0, nx));
    return {first, std::max(first, static_cast<std::size_t>(std::clamp(hi, 0.0, nx)))};
  }
};

/// Grey values of the membrane (inclusive), for fit_sample_cylinder.
struct GreyBand {
  double lo = 0.0, hi = 0.0;
};

/// Finds the sample cylinder from the solid mask (nz, ny, nx): its axis, radius and axial extent.
///
/// Rule: the xy occupancy O(y, x) is the fraction of z slices in which the column is solid. The
/// centre is the occupancy-weighted centroid of the columns. The radial profile of O (mean over
/// rings one voxel wide) has an interior level L (the median of the profile inside half the
/// equal-area radius r_a of the occupied columns); going outwards from r_a / 2, the radius is the
/// outer edge of the last ring before the profile first leaves [L / 2, (1 + L) / 2]: below, the air
/// around the sample; above, a membrane classified as solid (a vertical shell is solid in every
/// slice, O ~ 1).
/// The axial extent follows a similar rule along z: the solid fraction of each slice inside the
/// circle has an interior level L (median of the middle half of the slices); from the middle
/// slice up and down, the sample ends before the first slice whose fraction leaves
/// [L / 10, (1 + L) / 2] (the empty space a compressed sample leaves under its top platen, which
/// rests on the highest grains' tips; or a solid platen), at that slice's outer face. An end that reaches the volume's face stays open (infinite).
/// Grains touch a confining wall only at points, so the fitted radius lies a little inside it
/// (about 2 voxels for 9-voxel spheres against a rigid wall); give the cylinder when the membrane's
/// position is known. Throws DataError if the mask holds no solid.
Cylinder fit_sample_cylinder(const Volume<std::uint8_t>& solid);

/// The same with the membrane's grey band: voxels whose grey value lies in the band do not count as
/// solid, so a membrane that the threshold made solid cannot widen the cylinder. grey and solid
/// must have the same shape.
template <class T>
Cylinder fit_sample_cylinder(const Volume<std::uint8_t>& solid, const Volume<T>& grey, GreyBand membrane);

/// Volumes inside a region and the void ratio.
struct VoidRatio {
  double solid_m3 = 0.0;
  double void_m3 = 0.0;
  double e = 0.0;  ///< void_m3 / solid_m3
};

/// Counts solid (mask != 0) and void voxels whose centres lie inside `region`; e = V_void / V_solid.
/// Throws DataError if the region holds no solid voxel. Parallel over z, exact integer counts.
VoidRatio void_ratio(const Volume<std::uint8_t>& solid, const Cylinder& region);

/// The log volumetric strain eps_v = ln(V0 / V) = ln((1 + e0) / (1 + e)) of a sample whose void
/// ratio went from e0 to e at constant solid volume (compression positive).
double void_ratio_volumetric_strain(double e0, double e);

}  // namespace graintwin::segment
