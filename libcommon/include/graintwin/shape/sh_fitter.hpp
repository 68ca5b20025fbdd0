#pragma once
// Fitting many grains' radial functions r(direction) with spherical harmonics at once: every grain
// is sampled along the same directions, so the least-squares problem has the same design matrix
// for all of them; its pseudo-inverse is computed once and each fit is one matrix-vector product
// (the paper solved a least-squares system per grain).
#include <string>
#include <vector>

#include <Eigen/Core>

namespace graintwin::shape {

/// Product quadrature on the unit sphere: Gauss-Legendre in cos(theta) (n_theta nodes) times
/// n_phi equispaced azimuths; exact for polynomials in cos(theta) of degree 2 n_theta - 1 times
/// trigonometric polynomials in phi of degree n_phi - 1. Weights sum to 4 pi.
struct SphereQuadrature {
  std::vector<Eigen::Vector3d> directions;
  std::vector<double> weights;
};
SphereQuadrature sphere_quadrature(int n_theta, int n_phi);

/// Volume and centroid of a star-shaped body from its SH coefficients (see ShFitter::moments).
struct BodyMoments {
  double volume = 0.0;                                 ///< m^3
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< m, relative to the expansion origin
  double min_radius = 0.0;                             ///< smallest radius at the quadrature nodes
};

class ShFitter {
 public:
  /// Largest condition number of the design matrix accepted before the degree is lowered.
  static constexpr double kMaxCondition = 10.0;

  /// Fits up to `degree` from radii sampled along fibonacci_directions(n_directions) (0 = twice the
  /// number of coefficients, which keeps the condition number near 1.1). If the directions cannot
  /// support the degree (fewer directions than coefficients, or condition number above
  /// kMaxCondition) the degree is lowered until they can, and warning() says so. UsageError for
  /// degree < 0 or n_directions < 0.
  ShFitter(int degree, int n_directions = 0);

  /// Bytes a fitter of `degree` over `n_directions` (0 = automatic, as above) takes while it is
  /// built: the directions, the design matrix, its SVD and the pseudo-inverse, each directions x
  /// coefficients. For checking a request against the memory before building it.
  static double memory_bytes(int degree, int n_directions);
  /// The sample directions a request resolves to (n_directions, or 0 = twice the coefficients).
  static long long directions_for(int degree, int n_directions);

  int degree() const { return degree_; }
  int requested_degree() const { return requested_degree_; }
  /// Empty unless the degree was lowered; then one sentence saying why.
  const std::string& warning() const { return warning_; }
  double condition_number() const { return condition_; }
  const std::vector<Eigen::Vector3d>& directions() const { return directions_; }
  /// Design matrix A (directions x coefficients), A(i, k) = Y_k(direction i).
  const Eigen::MatrixXd& design() const { return design_; }

  /// Least-squares coefficients (sh_count(degree()) entries) of radii sampled along directions().
  Eigen::VectorXd fit(const Eigen::VectorXd& radii) const;

  /// RMS of the residual r - A_n c_n over the directions when the fit is truncated to degree n,
  /// for n = 0..degree() (degree() + 1 entries; the last is the full fit's residual). The basis is
  /// orthonormal on the sphere and the directions near-uniform, so truncating the full fit is the
  /// least-squares fit of the lower degree to within the design matrix's small non-orthogonality.
  Eigen::VectorXd truncation_rms(const Eigen::VectorXd& radii, const Eigen::VectorXd& coeffs) const;

  /// Exact volume and centroid of the body r <= sum_k c_k Y_k (coeffs of degree()): the basis is
  /// tabulated once at the nodes of sphere_quadrature(2L+1, 4L+2), which integrates r^4 exactly,
  /// so each call is one matrix-vector product.
  BodyMoments moments(const Eigen::VectorXd& coeffs) const;

 private:
  int requested_degree_ = 0;
  int degree_ = 0;
  std::string warning_;
  double condition_ = 1.0;
  std::vector<Eigen::Vector3d> directions_;
  Eigen::MatrixXd design_;
  Eigen::MatrixXd pseudo_inverse_;
  Eigen::MatrixXd quadrature_basis_;  ///< nodes x coefficients
  Eigen::VectorXd quadrature_weights_;
  Eigen::Matrix3Xd quadrature_directions_;
};

}  // namespace graintwin::shape
