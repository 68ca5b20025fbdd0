#include "graintwin/shape/sh_fitter.hpp"

#include <gsl/gsl_integration.h>

#include <Eigen/SVD>
#include <cmath>
#include <memory>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::shape {

SphereQuadrature sphere_quadrature(int n_theta, int n_phi) {
  if (n_theta < 1 || n_phi < 1) throw UsageError("a sphere quadrature needs at least one node per angle");
  std::unique_ptr<gsl_integration_glfixed_table, decltype(&gsl_integration_glfixed_table_free)> table(
      gsl_integration_glfixed_table_alloc(static_cast<std::size_t>(n_theta)), &gsl_integration_glfixed_table_free);
  SphereQuadrature q;
  const double w_phi = 2.0 * std::numbers::pi / n_phi;
  for (int i = 0; i < n_theta; ++i) {
    double x = 0.0, w_x = 0.0;
    gsl_integration_glfixed_point(-1.0, 1.0, static_cast<std::size_t>(i), &x, &w_x, table.get());
    const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
    for (int j = 0; j < n_phi; ++j) {
      const double phi = w_phi * j;
      q.directions.emplace_back(s * std::cos(phi), s * std::sin(phi), x);
      q.weights.push_back(w_x * w_phi);
    }
  }
  return q;
}

long long ShFitter::directions_for(int degree, int n_directions) {
  return n_directions > 0 ? n_directions : 2LL * sh_count(degree);
}

double ShFitter::memory_bytes(int degree, int n_directions) {
  const double n = static_cast<double>(directions_for(degree, n_directions));
  // Directions (3 doubles), then design, SVD U and pseudo-inverse (n x coefficients each) and
  // the SVD's workspace of about the same size.
  return n * (3.0 * 8.0 + 4.0 * 8.0 * sh_count(degree));
}

ShFitter::ShFitter(int degree, int n_directions) : requested_degree_(degree) {
  // The SVD's products run on Eigen's threads; with -j above the processor count they would spin.
  const EigenThreadCap cap;
  if (degree < 0) throw UsageError("the SH degree must be >= 0; give e.g. 15");
  if (n_directions < 0) throw UsageError("the number of sample directions must be >= 0 (0 = automatic)");
  const int n = static_cast<int>(directions_for(degree, n_directions));
  directions_ = fibonacci_directions(n);
  for (degree_ = std::min(degree, static_cast<int>(std::sqrt(static_cast<double>(n))) - 1); degree_ >= 0; --degree_) {
    design_ = sh_design_matrix(degree_, directions_);
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(design_, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& s = svd.singularValues();
    condition_ = s(0) / s(s.size() - 1);
    if (condition_ <= kMaxCondition) {
      pseudo_inverse_ = svd.matrixV() * s.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
      break;
    }
  }
  const SphereQuadrature q = sphere_quadrature(2 * degree_ + 1, 4 * degree_ + 2);
  quadrature_basis_ = sh_design_matrix(degree_, q.directions);
  quadrature_weights_ = Eigen::Map<const Eigen::VectorXd>(q.weights.data(), static_cast<Eigen::Index>(q.weights.size()));
  quadrature_directions_.resize(3, static_cast<Eigen::Index>(q.directions.size()));
  for (std::size_t i = 0; i < q.directions.size(); ++i) quadrature_directions_.col(static_cast<Eigen::Index>(i)) = q.directions[i];
  if (degree_ < degree)
    warning_ = "SH degree lowered from " + std::to_string(degree) + " to " + std::to_string(degree_) + ": " +
               std::to_string(n) + " sample directions cannot determine " + std::to_string(sh_count(degree)) +
               " coefficients stably; give more directions (at least twice the coefficients)";
}

Eigen::VectorXd ShFitter::fit(const Eigen::VectorXd& radii) const {
  if (radii.size() != static_cast<Eigen::Index>(directions_.size()))
    throw UsageError("ShFitter::fit needs one radius per sample direction");
  return pseudo_inverse_ * radii;
}

Eigen::VectorXd ShFitter::truncation_rms(const Eigen::VectorXd& radii, const Eigen::VectorXd& coeffs) const {
  Eigen::VectorXd residual = radii;
  Eigen::VectorXd out(degree_ + 1);
  const double inv_n = 1.0 / static_cast<double>(radii.size());
  for (int n = 0; n <= degree_; ++n) {
    // Degree n adds columns n^2 .. (n+1)^2 - 1.
    residual.noalias() -= design_.middleCols(n * n, 2 * n + 1) * coeffs.segment(n * n, 2 * n + 1);
    out(n) = std::sqrt(residual.squaredNorm() * inv_n);
  }
  return out;
}

BodyMoments ShFitter::moments(const Eigen::VectorXd& coeffs) const {
  if (coeffs.size() != quadrature_basis_.cols()) throw UsageError("ShFitter::moments needs coefficients of the fitter's degree");
  const Eigen::VectorXd r = quadrature_basis_ * coeffs;
  const Eigen::ArrayXd r3w = r.array().cube() * quadrature_weights_.array();
  BodyMoments m;
  m.volume = r3w.sum() / 3.0;
  m.centroid = quadrature_directions_ * (r3w * r.array()).matrix() / (4.0 * m.volume);
  m.min_radius = r.minCoeff();
  return m;
}

}  // namespace graintwin::shape
