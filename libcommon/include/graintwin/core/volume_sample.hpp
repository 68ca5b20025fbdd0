#pragma once
// Reading a float volume between its voxel centres.
#include <algorithm>
#include <cstddef>

#include "graintwin/core/volume.hpp"

namespace graintwin {

/// The trilinear interpolant of f at index coordinates (z, y, x) (voxel centres at whole numbers).
/// Callers keep them within [0, n - 1] on each axis; the upper neighbours are clamped to the last voxel.
inline float trilinear(const Volume<float>& f, double z, double y, double x) {
  const Shape3& s = f.shape();
  const auto z0 = static_cast<std::size_t>(z), y0 = static_cast<std::size_t>(y), x0 = static_cast<std::size_t>(x);
  const std::size_t z1 = std::min(z0 + 1, s[0] - 1), y1 = std::min(y0 + 1, s[1] - 1), x1 = std::min(x0 + 1, s[2] - 1);
  const double tz = z - static_cast<double>(z0), ty = y - static_cast<double>(y0), tx = x - static_cast<double>(x0);
  const double c00 = f(z0, y0, x0) + tx * (f(z0, y0, x1) - f(z0, y0, x0));
  const double c01 = f(z0, y1, x0) + tx * (f(z0, y1, x1) - f(z0, y1, x0));
  const double c10 = f(z1, y0, x0) + tx * (f(z1, y0, x1) - f(z1, y0, x0));
  const double c11 = f(z1, y1, x0) + tx * (f(z1, y1, x1) - f(z1, y1, x0));
  const double c0 = c00 + ty * (c01 - c00), c1 = c10 + ty * (c11 - c10);
  return static_cast<float>(c0 + tz * (c1 - c0));
}

}  // namespace graintwin
