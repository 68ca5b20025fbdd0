#pragma once
// The sizes of a grain of volume V as the sphere of the same volume: the one definition of the
// volume-equivalent diameter and radius, and of the sphericity that compares a grain's surface with
// that sphere's.
#include <cmath>
#include <numbers>

namespace graintwin {

/// The diameter of the sphere of volume `volume`: (6 V / pi)^(1/3).
inline double equivalent_diameter(double volume) { return std::cbrt(6.0 * volume / std::numbers::pi); }

/// The radius of the sphere of volume `volume`: (3 V / (4 pi))^(1/3).
inline double equivalent_radius(double volume) { return std::cbrt(3.0 * volume / (4.0 * std::numbers::pi)); }

/// Wadell's sphericity: the surface of the sphere of volume `volume` over the grain's `area`,
/// pi^(1/3) (6 V)^(2/3) / A (1 for a sphere, less for any other shape).
inline double sphericity(double volume, double area) {
  return std::cbrt(std::numbers::pi) * std::pow(6.0 * volume, 2.0 / 3.0) / area;
}

}  // namespace graintwin
