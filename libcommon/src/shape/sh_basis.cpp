// Real orthonormal spherical harmonics on GSL Legendre functions: values, design matrices,
// least-squares fits, invariants and Gauss-Legendre moments. Convention in sh_basis.hpp.
#include "graintwin/shape/sh_basis.hpp"

#include <gsl/gsl_integration.h>
#include <gsl/gsl_sf_legendre.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::shape {

namespace {

void require_coeffs(const Eigen::VectorXd& coeffs, int degree) {
  if (coeffs.size() != sh_count(degree)) {
    throw UsageError("an SH coefficient vector of degree " + std::to_string(degree) + " needs " +
                     std::to_string(sh_count(degree)) + " entries but has " +
                     std::to_string(coeffs.size()) + "; pass the degree the vector was made with");
  }
}

// Per-thread buffer of basis values, grown on demand, so hot loops do not allocate.
double* scratch_values(int degree) {
  thread_local std::vector<double> values;
  const auto k = static_cast<std::size_t>(sh_count(degree));
  if (values.size() < k) values.resize(k);
  return values.data();
}

}  // namespace

int sh_count(int degree) {
  if (degree < 0) {
    throw UsageError("an SH degree must be >= 0 (got " + std::to_string(degree) + ")");
  }
  return (degree + 1) * (degree + 1);
}

void real_sh_values(int degree, double cos_theta, double phi, double* out) {
  // GSL writes (degree+1)(degree+2)/2 values and uses the rest of its array_n-sized buffer as
  // workspace, so the buffer must be sized with gsl_sf_legendre_array_n.
  thread_local std::vector<double> legendre;
  const std::size_t lmax = static_cast<std::size_t>(degree);
  const std::size_t need = gsl_sf_legendre_array_n(lmax);
  if (legendre.size() < need) legendre.resize(need);
  const double x = std::clamp(cos_theta, -1.0, 1.0);
  gsl_sf_legendre_array_e(GSL_SF_LEGENDRE_SPHARM, lmax, x, 1.0, legendre.data());
  // P(n, m) sits at n(n+1)/2 + m (gsl_sf_legendre_array_index).
  for (int n = 0; n <= degree; ++n) out[n * n + n] = legendre[n * (n + 1) / 2];
  const double c1 = std::cos(phi);
  const double s1 = std::sin(phi);
  double cm = 1.0;
  double sm = 0.0;
  for (int m = 1; m <= degree; ++m) {
    // (cos m phi, sin m phi) by rotating the previous angle by phi: stable, no further trig.
    const double c_next = cm * c1 - sm * s1;
    sm = sm * c1 + cm * s1;
    cm = c_next;
    for (int n = m; n <= degree; ++n) {
      const double p = std::numbers::sqrt2 * legendre[n * (n + 1) / 2 + m];
      out[n * n + n + m] = p * cm;
      out[n * n + n - m] = p * sm;
    }
  }
}

Eigen::MatrixXd sh_design_matrix(int degree, const std::vector<Eigen::Vector3d>& unit_dirs) {
  const int k = sh_count(degree);
  const auto rows = static_cast<std::ptrdiff_t>(unit_dirs.size());
  for (const Eigen::Vector3d& d : unit_dirs) {
    if (!(d.squaredNorm() > 0.0) || !d.allFinite()) {
      throw UsageError("sh_design_matrix got a zero or non-finite direction; pass non-zero "
                       "direction vectors");
    }
  }
  Eigen::MatrixXd a(rows, k);
#pragma omp parallel for schedule(static) if (rows > 256)
  for (std::ptrdiff_t i = 0; i < rows; ++i) {
    const Eigen::Vector3d& d = unit_dirs[static_cast<std::size_t>(i)];
    double* values = scratch_values(degree);
    real_sh_values(degree, d.z() / d.norm(), std::atan2(d.y(), d.x()), values);
    for (int j = 0; j < k; ++j) a(i, j) = values[j];
  }
  return a;
}

double sh_radius(const Eigen::VectorXd& coeffs, int degree, const Eigen::Vector3d& unit_dir) {
  require_coeffs(coeffs, degree);
  double* values = scratch_values(degree);
  real_sh_values(degree, unit_dir.z() / unit_dir.norm(), std::atan2(unit_dir.y(), unit_dir.x()),
                 values);
  return Eigen::Map<const Eigen::VectorXd>(values, coeffs.size()).dot(coeffs);
}

Eigen::VectorXd sh_invariants(const Eigen::VectorXd& coeffs, int degree) {
  require_coeffs(coeffs, degree);
  Eigen::VectorXd inv(degree + 1);
  for (int n = 0; n <= degree; ++n) inv[n] = coeffs.segment(n * n, 2 * n + 1).norm();
  return inv;
}

std::vector<Eigen::Vector3d> fibonacci_directions(int n) {
  if (n < 1) {
    throw UsageError("fibonacci_directions needs n >= 1 (got " + std::to_string(n) + ")");
  }
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> dirs(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    // Equal-area bands in z (cell centres), golden-angle steps in azimuth.
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    dirs[static_cast<std::size_t>(i)] = Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), z);
  }
  return dirs;
}

Eigen::VectorXd sh_fit(const std::function<double(const Eigen::Vector3d&)>& r, int degree,
                       int n_dirs) {
  const int k = sh_count(degree);
  if (n_dirs < k) {
    throw UsageError("sh_fit of degree " + std::to_string(degree) + " needs at least " +
                     std::to_string(k) + " directions (got " + std::to_string(n_dirs) +
                     "); use about " + std::to_string(2 * k));
  }
  const std::vector<Eigen::Vector3d> dirs = fibonacci_directions(n_dirs);
  Eigen::VectorXd b(n_dirs);
  for (int i = 0; i < n_dirs; ++i) {
    b[i] = r(dirs[static_cast<std::size_t>(i)]);
    if (!std::isfinite(b[i])) {
      throw DataError("sh_fit: the sampled function is not finite along a direction; fix the "
                      "function so it is defined on the whole sphere");
    }
  }
  return sh_design_matrix(degree, dirs).householderQr().solve(b);
}

ShMoments sh_moments(const Eigen::VectorXd& coeffs, int degree) {
  require_coeffs(coeffs, degree);
  // r^4 * dir has degree 4L+1: Gauss-Legendre with 2L+1 nodes is exact for polynomial degree
  // 4L+1 in cos(theta), and 4L+2 equispaced azimuths are exact for trig degree 4L+1.
  const int n_theta = 2 * degree + 1;
  const int n_phi = 4 * degree + 2;
  std::unique_ptr<gsl_integration_glfixed_table, decltype(&gsl_integration_glfixed_table_free)>
      table(gsl_integration_glfixed_table_alloc(static_cast<std::size_t>(n_theta)),
            &gsl_integration_glfixed_table_free);
  const int k = sh_count(degree);
  std::vector<double> values(static_cast<std::size_t>(k));
  double vol = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  double r_min = std::numeric_limits<double>::infinity();
  const double w_phi = 2.0 * std::numbers::pi / n_phi;
  const Eigen::Map<const Eigen::VectorXd> basis(values.data(), k);
  for (int i = 0; i < n_theta; ++i) {
    double x = 0.0;
    double w_x = 0.0;
    gsl_integration_glfixed_point(-1.0, 1.0, static_cast<std::size_t>(i), &x, &w_x, table.get());
    const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
    for (int j = 0; j < n_phi; ++j) {
      const double phi = w_phi * j;
      real_sh_values(degree, x, phi, values.data());
      const double r = basis.dot(coeffs);
      const double w = w_x * w_phi;
      const double r3 = r * r * r;
      vol += r3 / 3.0 * w;
      first += (r3 * r / 4.0 * w) * Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), x);
      r_min = std::min(r_min, r);
    }
  }
  ShMoments m;
  m.volume = vol;
  m.centroid = first / vol;
  m.min_sampled_radius = r_min;
  return m;
}

RadialTable radial_table_from_sh(const Eigen::VectorXd& coeffs, int degree, int n) {
  require_coeffs(coeffs, degree);
  const std::vector<Eigen::Vector3d> dirs = RadialTable::node_directions(n);
  std::vector<double> radii(dirs.size());
  const auto count = static_cast<std::ptrdiff_t>(dirs.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t q = 0; q < count; ++q) {
    const auto i = static_cast<std::size_t>(q);
    radii[i] = sh_radius(coeffs, degree, dirs[i]);
  }
  return RadialTable::from_node_radii(n, std::move(radii));
}

}  // namespace graintwin::shape
