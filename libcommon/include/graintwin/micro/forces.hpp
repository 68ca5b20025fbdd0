#pragma once
// Contact-force and grain-stress statistics of a simulated state (docs/methods.md, micro-mechanics), as plain
// functions for fdem2forces: the PDF of f_n / <f_n> with an exponential fit of the strong forces
// (above the mean) and a power-law fit of the weak ones (below), the rose of mean normal force per
// direction, the grain stress q, its volatility over a strain window, and Pearson's r with its
// two-sided p-value (GSL's t distribution).
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "graintwin/micro/distributions.hpp"

namespace graintwin::micro {

/// Weak forces: P(f) = (theta + 1) f^theta on (0, 1] (f = f_n / <f_n>), fitted by maximum
/// likelihood: theta = -1 - n / sum ln f, error (theta + 1) / sqrt(n). theta > -1 always.
struct WeakForceFit {
  double theta = 0.0, theta_error = 0.0;
  std::size_t count = 0;
  bool valid = false;
};
WeakForceFit fit_weak_forces(const std::vector<double>& normalised);

struct ForceDistribution {
  double mean = 0.0;              ///< <f_n> over the positive forces, N
  std::vector<double> normalised; ///< f_n / <f_n> of each positive force, in input order of those
  Histogram pdf;                  ///< log bins of f_n / <f_n>
  ExponentialFit strong;          ///< P(f) ~ exp(-(f - 1) / scale) for f >= 1
  WeakForceFit weak;              ///< P(f) ~ f^theta for f < 1
};
/// `normal_forces` in N; zero, negative (no contact) and non-finite entries are left out.
ForceDistribution force_distribution(const std::vector<double>& normal_forces, double per_decade);

/// Mean normal force per direction bin, the bins of contacts::rose (normals folded onto the upper
/// hemisphere, theta from +z over [0, pi/2], phi from +x over [0, 2 pi]).
struct ForceRose {
  std::vector<double> theta_edges, phi_edges;  ///< rad
  std::vector<std::uint64_t> counts;           ///< n_theta x n_phi, theta slowest
  std::vector<double> mean_force;              ///< N, NaN in empty bins
};
ForceRose force_rose(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& normal_forces, int theta_bins,
                     int phi_bins);

/// q = sqrt(1/2 s_ij s_ij), s the deviatoric part of the (symmetric) stress tensor, Pa. This is
/// the CT-FDEM paper's definition: it is the second invariant sqrt(J2), not von Mises' sqrt(3 J2).
double deviatoric_stress_q(const Eigen::Matrix3d& stress);

/// Volatility of a series q_0..q_N (one grain over a strain window): returns R_i = ln(q_i / q_{i-1}),
/// V = sqrt(1/(N-1) sum (R_i - mean R)^2) (sample standard deviation). NaN with fewer than two
/// returns or a non-positive q.
double volatility(const std::vector<double>& q);

/// Pearson's correlation coefficient and its two-sided p-value from t = r sqrt((n-2)/(1-r^2)) with
/// n - 2 degrees of freedom. Pairs with a non-finite member are skipped; n < 3 gives NaN.
struct Correlation {
  double r = 0.0, p_value = 0.0;
  std::size_t count = 0;
};
Correlation pearson(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace graintwin::micro
