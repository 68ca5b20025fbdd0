#pragma once
// Real orthonormal spherical harmonics (docs/methods.md, spherical harmonics) for radial surfaces r(theta, phi):
// evaluation, least-squares fitting, rotation invariants ||R_n|| and exact volume/centroid.
//
// Convention (fixed here, used by every coefficient vector in the project):
//   theta = polar angle from +z, phi = azimuth from +x (body frame).
//   Index of (n, m) is n*n + n + m, m = -n..n, n = 0..degree; a degree-L vector has (L+1)^2
//   entries.
//   Y_n^0  = Nbar_n^0 P_n^0(cos theta)
//   Y_n^m  = sqrt(2) Nbar_n^m P_n^m(cos theta) cos(m phi)     (m > 0)
//   Y_n^-m = sqrt(2) Nbar_n^m P_n^m(cos theta) sin(m phi)     (m > 0)
//   with Nbar_n^m P_n^m = sqrt((2n+1)/(4 pi) (n-m)!/(n+m)!) P_n^m (GSL's GSL_SF_LEGENDRE_SPHARM) and
//   WITHOUT the Condon-Shortley phase (-1)^m (GSL csphase = +1, as SHTOOLS). The basis is
//   orthonormal over the unit sphere, so sum_m c_nm^2 is the L2 energy of degree n, and a sphere of
//   radius r has c_00 = r sqrt(4 pi). Degrees up to 100 are supported (UsageError beyond).
#include <Eigen/Core>
#include <functional>
#include <vector>

#include "graintwin/shape/radial_table.hpp"

namespace graintwin::shape {

/// The basis description stored beside every coefficient table (attribute `basis`) of the shapes
/// and ground truth files.
inline constexpr const char* kShBasisDescription =
    "real orthonormal, index n*n+n+m, no Condon-Shortley phase (graintwin/shape/sh_basis.hpp)";

/// Number of real SH of degree 0..degree: (degree+1)^2. Throws UsageError for degree < 0.
int sh_count(int degree);

/// Writes the sh_count(degree) basis values Y_n^m(theta, phi) to out (index n*n + n + m).
/// cos_theta is clamped to [-1, 1]. Evaluated in Cartesian form by a Legendre recurrence with
/// tabulated coefficients (no trigonometry per degree); thread-safe and allocation-free.
void real_sh_values(int degree, double cos_theta, double phi, double* out);

/// Design matrix A (unit_dirs.size() x sh_count(degree)), A(i, k) = Y_k(unit_dirs[i]).
/// Directions need not be normalised but must be non-zero (UsageError otherwise). Rows are filled
/// in parallel (OpenMP).
Eigen::MatrixXd sh_design_matrix(int degree, const std::vector<Eigen::Vector3d>& unit_dirs);

/// r(unit_dir) = sum_k coeffs[k] Y_k(unit_dir) (units of the coefficients, metres for a surface).
/// coeffs must have sh_count(degree) entries (UsageError otherwise); unit_dir must be non-zero.
double sh_radius(const Eigen::VectorXd& coeffs, int degree, const Eigen::Vector3d& unit_dir);

/// Rotation invariants ||R_n|| = sqrt(sum_m c_nm^2), n = 0..degree (degree+1 entries).
Eigen::VectorXd sh_invariants(const Eigen::VectorXd& coeffs, int degree);

/// n >= 1 quasi-uniform unit directions on a Fibonacci (golden-angle) spiral, z from ~+1 to ~-1.
std::vector<Eigen::Vector3d> fibonacci_directions(int n);

/// Least-squares SH coefficients (sh_count(degree) entries) of r sampled at
/// fibonacci_directions(n_dirs) (Householder QR). n_dirs must be >= sh_count(degree); about twice
/// that keeps the system well conditioned (cond ~ 1.1). Band-limited r are recovered to ~1e-14.
/// Throws DataError if r returns a non-finite value.
Eigen::VectorXd sh_fit(const std::function<double(const Eigen::Vector3d&)>& r, int degree,
                       int n_dirs);

/// Volume, centroid and sampled minimum radius of the body |x| <= sh_radius(coeffs, degree, x).
struct ShMoments {
  double volume = 0.0;                                  ///< m^3, integral of r^3/3 over the sphere
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();   ///< m, integral of r^4/4 dir / volume
  double min_sampled_radius = 0.0;                      ///< m, min of r over the quadrature nodes
};

/// Exact (to rounding) volume and centroid by Gauss-Legendre quadrature in cos(theta) with
/// 2*degree+1 nodes times 4*degree+2 equispaced azimuths, which integrates r^4 * dir exactly for a
/// band-limited r. The minimum is only over those nodes (spacing ~ pi / (2 degree + 1)).
ShMoments sh_moments(const Eigen::VectorXd& coeffs, int degree);

/// Cube-map table of the SH surface (see RadialTable), the nodes evaluated row by row from the
/// surface's polynomial form (agrees with sh_radius() to ~1e-13 relative; ~1 ms at n = 120,
/// degree 15).
/// Throws DataError if r <= 0 at some node (the surface is not star-shaped about its origin).
RadialTable radial_table_from_sh(const Eigen::VectorXd& coeffs, int degree, int n = 64);

}  // namespace graintwin::shape
