#pragma once
// A grain's rotation between two scans (docs/shapes2tracks.md). Principal axes first: the inertia
// ellipsoids' axes give the rotation up to the sign of each axis (4 right-handed choices); the SH
// surfaces decide the signs (the rotated first surface must match the second). Then, optionally,
// the rotation is refined by aligning the SH surfaces themselves (Gauss-Newton on the radial misfit
// over rotation vectors), which also covers grains whose ellipsoid is nearly symmetric. A rotation
// is reported undefined when the data cannot tell it: no clear winner among the candidates.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "graintwin/shape/grain_measure.hpp"

namespace graintwin::track {

enum class RotationMethod { none, axes, sh };

struct RotationOptions {
  RotationMethod method = RotationMethod::sh;
  /// Semi-axes whose relative difference is below this make the principal axes ambiguous.
  double symmetry_tol = 0.05;
  /// The chosen rotation must fit at least this much better (misfit ratio) than the best
  /// alternative that differs by more than 10 degrees, or it is undefined.
  double min_margin = 1.3;
  int degree = 8;  ///< SH degree of the surface comparison (form and roundness; lower is faster)
};

struct RotationEstimate {
  /// Maps the grain's pose in the first scan to the second, about its centroid, world axes:
  /// x_b - c_b = R (x_a - c_a). Unit, w >= 0.
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  bool defined = false;
  double misfit = 0.0;  ///< RMS radial difference of the surfaces after rotation / equivalent radius of b
  double margin = 0.0;  ///< misfit of the best distinct alternative / misfit
};

/// Semi-axes (a >= b >= c) and directions (columns, right-handed) of the inertia-equivalent
/// ellipsoid of the SH body r <= sum_k c_k Y_k (quadrature of r^5 / 5 d d^T, exact for the degree):
/// the same convention as labels2shapes' voxel moments, for bodies known only by their surface.
void inertia_ellipsoid(const Eigen::VectorXd& coeffs, int degree, Eigen::Vector3d& semi_axes, Eigen::Matrix3d& axes);

/// UsageError naming the others for anything but "sh", "axes" or "none".
RotationMethod parse_rotation_method(const std::string& name);
/// The name parse_rotation_method() reads ("sh", "axes", "none"), as the tracks file stores it.
const char* rotation_method_name(RotationMethod method);

class RotationEstimator {
 public:
  /// coeff_degree: degree of the coefficient vectors to be compared (the shapes files'). UsageError
  /// for invalid options.
  RotationEstimator(int coeff_degree, const RotationOptions& options);
  /// Thread-safe.
  RotationEstimate estimate(const shape::GrainShape& a, const shape::GrainShape& b) const;
  /// RMS radial difference between b and a rotated by r, over b's equivalent radius.
  double misfit(const shape::GrainShape& a, const shape::GrainShape& b, const Eigen::Matrix3d& r) const;

 private:
  Eigen::VectorXd radii(const shape::GrainShape& g, const Eigen::Matrix3d& r) const;
  RotationOptions options_;
  int degree_ = 0;                          ///< comparison degree
  std::vector<Eigen::Vector3d> directions_; ///< comparison directions (Fibonacci)
  Eigen::MatrixXd design_;                  ///< Y at directions_
};

}  // namespace graintwin::track
