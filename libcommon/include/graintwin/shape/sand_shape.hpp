#pragma once
// Random realistic sand-grain shapes as SH coefficient vectors (sh_basis.hpp convention), after
// Wei, Wang & Zhao 2018 (Powder Technology 330: 284-291), adapted to the radial form r(theta, phi):
// the rotation invariants D_n = ||R_n|| relative to D_0 set the shape at three scales, and the
// coefficients within each degree get a random direction. Also reference shapes (sphere,
// ellipsoid) and the shape statistics used to calibrate and check the generator.
#include <Eigen/Core>
#include <random>

#include "graintwin/shape/radial_table.hpp"

namespace graintwin::shape {

/// Spectrum of a random grain, as ratios Dhat_n = D_n / D_0 (D_0 = sqrt(4 pi) x mean radius):
///   Dhat_1 = 0 (degree 1 is a translation to first order; the centroid is fixed separately),
///   Dhat_2 ~ uniform in d2 * [1 - d2_spread, 1 + d2_spread]      (form: elongation, flatness),
///   Dhat_n = Dhat_2 (n / 2)^-roundness_exponent                for 3 <= n < roughness_from_degree,
///   Dhat_n = Dhat_{n_r} (n / n_r)^-roughness_exponent, n_r = roughness_from_degree, for n >= n_r
///   (continuous at n_r; Dhat_{n_r} from the roundness law). Both laws are anchored at the drawn
///   Dhat_2, as in Wei et al.; larger exponents give rounder, smoother grains.
/// Real sand varies from grain to grain at every scale, not only in form, so each grain also draws
/// its own exponents (uniform in exponent * [1 - exponent_spread, 1 + exponent_spread], the two
/// independently) and a log-normal factor exp(degree_jitter N(0, 1)) on every Dhat_n, n >= 3.
/// Without them (both 0) every grain's spectrum is Dhat_2 times one fixed curve, and grains are
/// told apart by their invariants only through Dhat_2. The defaults are calibrated to Ottawa sand
/// at degree 15 (see random_sand_coeffs); a higher degree with the same parameters adds roughness,
/// so it lowers sphericity.
struct SandShapeParams {
  int degree = 15;                   ///< max SH degree, >= 2 (tested up to 20)
  double d2 = 0.085;                 ///< mean Dhat_2, >= 0
  double d2_spread = 0.35;           ///< relative half-width of the Dhat_2 distribution, in [0, 1)
  double roundness_exponent = 1.0;   ///< power-law exponent for degrees 3 .. n_r - 1
  double roughness_exponent = 2.0;   ///< power-law exponent for degrees n_r .. degree
  int roughness_from_degree = 8;     ///< n_r, in [3, degree + 1] (degree + 1: no roughness band)
  double exponent_spread = 0.2;      ///< per-grain relative half-width of both exponents, [0, 1)
  double degree_jitter = 0.15;       ///< per-grain, per-degree log-normal sigma of Dhat_n, >= 0
};

/// A random grain: SH coefficients (sh_count(degree) entries) of a surface whose
/// volume-equivalent radius is 1 m (scale the result, or its RadialTable, to size) and whose
/// centroid is at the SH origin to within 1e-5 of that radius. Invariants are drawn as in
/// SandShapeParams, then the surface is re-fitted about its true centroid (ray lengths from the
/// centroid on 2 (degree+1)^2 Fibonacci directions) until the centroid offset is < 1e-5, and
/// rescaled. A draw is rejected and redrawn if the re-fit does not converge (not star-shaped about
/// its centroid) or if r < 0.1 anywhere on the Gauss-Legendre and fit grids (that margin keeps
/// r > 0 between the samples), so every returned grain is star-shaped with r > 0 everywhere.
/// Deterministic for a given rng state. Throws UsageError for invalid parameters and DataError if
/// 1000 draws in a row are rejected (the parameters describe grains too irregular for
/// r(theta, phi)).
///
/// With the default parameters and degree 15, 200 grains measured (RadialTable n = 64) aspect ratio
/// 1.35 +- 0.08 and sphericity 0.877 +- 0.043 (mean +- standard deviation; Ottawa sand: about
/// 1.2-1.5 and 0.85-0.92 on average). A grain takes 1-2 ms (one core).
Eigen::VectorXd random_sand_coeffs(const SandShapeParams& params, std::mt19937_64& rng);

/// Coefficients of a sphere of the given radius (metres, > 0): c_00 = radius sqrt(4 pi), all
/// other sh_count(degree) - 1 entries zero.
Eigen::VectorXd sphere_coeffs(double radius, int degree = 0);

/// Radial table (n nodes per cube-face edge) of the ellipsoid with semi-axes a, b, c (metres, > 0)
/// along body x, y, z, centred at the origin: r(d) = 1 / sqrt(dx^2/a^2 + dy^2/b^2 + dz^2/c^2).
RadialTable ellipsoid_table(double a, double b, double c, int n = 64);

/// Size and shape descriptors of a tabulated body.
struct ShapeStats {
  double volume = 0.0;               ///< m^3
  double surface_area = 0.0;         ///< m^2
  double equivalent_diameter = 0.0;  ///< m, diameter of the sphere of equal volume, (6V/pi)^(1/3)
  double sphericity = 0.0;           ///< Wadell: pi^(1/3) (6V)^(2/3) / A, 1 for a sphere
  double aspect_ratio = 0.0;         ///< semi_axes[0] / semi_axes[2] (longest / shortest), >= 1
  /// Semi-axes (m), descending, of the inertia-equivalent ellipsoid: the uniform solid ellipsoid
  /// with the same centroidal second moment per unit volume, a_i = sqrt(5 lambda_i / V) with
  /// lambda_i the eigenvalues of M = integral of (x - c)(x - c)^T dV. Equal to (a, b, c) for an
  /// ellipsoid.
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Zero();
  /// Columns: unit directions of semi_axes[0], [1], [2] in the table's frame (right-handed).
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
};

/// Sets s.semi_axes, s.axes and s.aspect_ratio: the inertia-equivalent ellipsoid of a body whose
/// centroidal second moment per unit volume is `m` (integral of (x - c)(x - c)^T dV / V).
void set_equivalent_ellipsoid(ShapeStats& s, const Eigen::Matrix3d& m);

/// Shape statistics of a table (from its volume, surface area and inertia tensor).
ShapeStats shape_stats(const RadialTable& table);

}  // namespace graintwin::shape
