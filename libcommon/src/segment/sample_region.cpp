#include "graintwin/segment/sample_region.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"

namespace graintwin::segment {
namespace {

/// Solid count per (y, x) column; `keep(i)` says whether solid voxel i counts.
template <class Keep>
std::vector<std::uint32_t> column_counts(const Volume<std::uint8_t>& solid, Keep keep) {
  const Shape3& s = solid.shape();
  const std::size_t plane = s[1] * s[2];
  std::vector<std::uint32_t> count(plane, 0);
  const std::uint8_t* m = solid.data();
  // Parallel over columns' rows (y): every thread owns its counts, no reduction needed.
#pragma omp parallel for schedule(static)
  for (std::size_t y = 0; y < s[1]; ++y)
    for (std::size_t z = 0; z < s[0]; ++z) {
      const std::size_t base = z * plane + y * s[2];
      for (std::size_t x = 0; x < s[2]; ++x)
        if (m[base + x] && keep(base + x)) ++count[y * s[2] + x];
    }
  return count;
}

Cylinder fit_from_counts(const Volume<std::uint8_t>& solid, const std::vector<std::uint32_t>& count) {
  const Shape3& s = solid.shape();
  const Vec3& vs = solid.voxel_size();
  const double nz = static_cast<double>(s[0]);
  double w = 0.0, wx = 0.0, wy = 0.0;
  std::size_t occupied = 0;
  for (std::size_t y = 0; y < s[1]; ++y)
    for (std::size_t x = 0; x < s[2]; ++x) {
      const double o = count[y * s[2] + x] / nz;
      w += o, wx += o * static_cast<double>(x), wy += o * static_cast<double>(y);
      occupied += o > 0.0;
    }
  if (w == 0.0) throw DataError("the solid mask is empty, so there is no sample to fit a cylinder to; check the threshold");
  // Work in index units of x (y scaled by dy/dx) so that rings are round in physical space.
  const double cx = wx / w, cy = wy / w, ay = vs[1] / vs[2];
  const double equal_area_r = std::sqrt(static_cast<double>(occupied) * ay / M_PI);
  const double r_max = std::hypot(std::max(cx, static_cast<double>(s[2]) - cx), std::max(cy, static_cast<double>(s[1]) - cy) * ay);
  const std::size_t rings = static_cast<std::size_t>(std::ceil(r_max)) + 1;
  std::vector<double> sum(rings, 0.0);
  std::vector<std::size_t> cnt(rings, 0);
  for (std::size_t y = 0; y < s[1]; ++y)
    for (std::size_t x = 0; x < s[2]; ++x) {
      const double r = std::hypot(static_cast<double>(x) - cx, (static_cast<double>(y) - cy) * ay);
      const auto ring = static_cast<std::size_t>(r);
      sum[ring] += count[y * s[2] + x] / nz;
      ++cnt[ring];
    }
  std::vector<double> profile(rings, 0.0);
  for (std::size_t i = 0; i < rings; ++i) profile[i] = cnt[i] ? sum[i] / static_cast<double>(cnt[i]) : -1.0;
  // The inner rings set the level; the search for the edge starts beyond them, where rings hold
  // enough columns for their mean to be steady.
  const auto inner_rings = std::max<std::size_t>(1, static_cast<std::size_t>(0.5 * equal_area_r));
  std::vector<double> inner;
  for (std::size_t i = 0; i < rings && (i < inner_rings || inner.empty()); ++i)
    if (cnt[i]) inner.push_back(profile[i]);
  const double level = median(inner);
  const double lo = 0.5 * level, hi = 0.5 * (1.0 + level);
  std::size_t edge = std::min(inner_rings, rings);  // rings [0, edge) are inside
  while (edge < rings && (cnt[edge] == 0 || (profile[edge] >= lo && profile[edge] <= hi))) ++edge;
  Cylinder c;
  const Vec3 centre = solid.position_xyz(0.0, cy, cx);
  c.centre_x = centre[0];
  c.centre_y = centre[1];
  c.radius = static_cast<double>(edge) * vs[2];
  return c;
}

/// The sample's axial extent inside the fitted circle: the slices' solid fractions have an interior
/// level L (median over the middle half of the slices); going up and down from the middle, the
/// sample ends at the last slice before the fraction leaves [L / 10, (1 + L) / 2] (below: the space
/// a compressed sample leaves under the top platen, which rests on the highest grains' tips, hence
/// L / 10 and not L / 2, which would cut the rough top layer in half; above: a solid platen). A
/// sample that reaches the volume's end keeps an open end (a crop from inside a sample).
void fit_axial_extent(const Volume<std::uint8_t>& solid, Cylinder& c) {
  const Shape3& s = solid.shape();
  std::vector<double> fraction(s[0], 0.0);
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z) {
    std::size_t inside = 0, filled = 0;
    for (std::size_t y = 0; y < s[1]; ++y) {
      const auto [first, last] = c.row_span(solid, z, y);
      inside += last - first;
      for (std::size_t x = first; x < last; ++x) filled += solid(z, y, x) != 0;
    }
    fraction[z] = inside ? static_cast<double>(filled) / static_cast<double>(inside) : 0.0;
  }
  std::vector<double> middle(fraction.begin() + static_cast<std::ptrdiff_t>(s[0] / 4),
                             fraction.begin() + static_cast<std::ptrdiff_t>(std::max(s[0] / 4 + 1, 3 * s[0] / 4)));
  const double level = median(middle);
  const auto in_sample = [&](std::size_t z) { return fraction[z] >= 0.1 * level && fraction[z] <= 0.5 * (1.0 + level); };
  const std::size_t mid = s[0] / 2;
  std::size_t top = mid, bottom = mid;
  while (top + 1 < s[0] && in_sample(top + 1)) ++top;
  while (bottom > 0 && in_sample(bottom - 1)) --bottom;
  const double dz = solid.voxel_size()[0];
  if (bottom > 0) c.z_min = solid.position_xyz(static_cast<double>(bottom), 0.0, 0.0)[2] - 0.5 * dz;
  if (top + 1 < s[0]) c.z_max = solid.position_xyz(static_cast<double>(top), 0.0, 0.0)[2] + 0.5 * dz;
}

}  // namespace

Cylinder fit_sample_cylinder(const Volume<std::uint8_t>& solid) {
  Cylinder c = fit_from_counts(solid, column_counts(solid, [](std::size_t) { return true; }));
  fit_axial_extent(solid, c);
  return c;
}

template <class T>
Cylinder fit_sample_cylinder(const Volume<std::uint8_t>& solid, const Volume<T>& grey, GreyBand membrane) {
  if (grey.shape() != solid.shape())
    throw UsageError("the grey volume and the solid mask differ in shape; threshold the same volume you pass");
  if (!(membrane.lo <= membrane.hi))
    throw UsageError("the membrane grey band needs lo <= hi");
  const T* g = grey.data();
  Cylinder c = fit_from_counts(solid, column_counts(solid, [&](std::size_t i) {
                                 const double v = static_cast<double>(g[i]);
                                 return v < membrane.lo || v > membrane.hi;
                               }));
  fit_axial_extent(solid, c);
  return c;
}

VoidRatio void_ratio(const Volume<std::uint8_t>& solid, const Cylinder& region) {
  const Shape3& s = solid.shape();
  std::uint64_t n_solid = 0, n_all = 0;
#pragma omp parallel for schedule(static) reduction(+ : n_solid, n_all)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x)
        if (region.contains(solid, z, y, x)) {
          ++n_all;
          n_solid += solid(z, y, x) != 0;
        }
  if (n_solid == 0)
    throw DataError("the sample region holds no solid voxel, so the void ratio is undefined; check the cylinder and the threshold");
  const Vec3& vs = solid.voxel_size();
  const double voxel = vs[0] * vs[1] * vs[2];
  VoidRatio r;
  r.solid_m3 = static_cast<double>(n_solid) * voxel;
  r.void_m3 = static_cast<double>(n_all - n_solid) * voxel;
  r.e = r.void_m3 / r.solid_m3;
  return r;
}

template Cylinder fit_sample_cylinder(const Volume<std::uint8_t>&, const Volume<std::uint8_t>&, GreyBand);
template Cylinder fit_sample_cylinder(const Volume<std::uint8_t>&, const Volume<std::uint16_t>&, GreyBand);
template Cylinder fit_sample_cylinder(const Volume<std::uint8_t>&, const Volume<float>&, GreyBand);

double void_ratio_volumetric_strain(double e0, double e) { return std::log((1.0 + e0) / (1.0 + e)); }

}  // namespace graintwin::segment
