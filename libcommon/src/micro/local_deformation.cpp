#include "graintwin/micro/local_deformation.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"

namespace graintwin::micro {

bool affine_fit(const std::vector<Eigen::Vector3d>& before, const std::vector<Eigen::Vector3d>& after,
                double min_conditioning, Eigen::Matrix3d& lambda, double& d2min_m2) {
  if (before.size() != after.size()) throw UsageError("affine_fit: the two neighbourhoods differ in size");
  if (before.empty()) return false;
  Eigen::Matrix3d x = Eigen::Matrix3d::Zero(), y = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < before.size(); ++k) {
    x += after[k] * before[k].transpose();
    y += before[k] * before[k].transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(y, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (!(ev[2] > 0.0) || ev[0] < min_conditioning * ev[2]) return false;
  lambda = x * y.inverse();
  double sum = 0.0;
  for (std::size_t k = 0; k < before.size(); ++k) sum += (after[k] - lambda * before[k]).squaredNorm();
  d2min_m2 = sum / static_cast<double>(before.size());
  return true;
}

Eigen::Matrix<double, 6, 1> local_strain(const Eigen::Matrix3d& lambda) {
  const Eigen::Matrix3d e = Eigen::Matrix3d::Identity() - 0.5 * (lambda + lambda.transpose());
  Eigen::Matrix<double, 6, 1> v;
  v << e(0, 0), e(1, 1), e(2, 2), e(1, 2), e(0, 2), e(0, 1);
  return v;
}

double deviatoric_strain(const Eigen::Matrix<double, 6, 1>& s) {
  const double mean = (s[0] + s[1] + s[2]) / 3.0;
  const double dxx = s[0] - mean, dyy = s[1] - mean, dzz = s[2] - mean;
  const double contraction = dxx * dxx + dyy * dyy + dzz * dzz + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
  return std::sqrt(2.0 / 3.0 * contraction);
}

std::vector<LocalDeformation> local_deformation(const std::vector<Eigen::Vector3d>& before,
                                                const std::vector<Eigen::Vector3d>& after,
                                                const DeformationOptions& o) {
  if (before.size() != after.size()) throw UsageError("local_deformation: the two states hold different grain counts");
  if (!(o.radius > 0.0) || !(o.d50 > 0.0)) throw UsageError("local_deformation: the radius and d50 must be positive");
  const std::size_t n = before.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Only grains present in both states are indexed, so nobody takes a missing grain as a neighbour.
  std::vector<Eigen::Vector3d> indexed(n);
  for (std::size_t i = 0; i < n; ++i)
    indexed[i] = before[i].allFinite() && after[i].allFinite() ? before[i] : Eigen::Vector3d::Constant(nan);
  const PointGrid grid(indexed, o.radius);
  std::vector<LocalDeformation> out(n);
  const double inv_d2 = 1.0 / (o.d50 * o.d50);
#pragma omp parallel
  {
    std::vector<Eigen::Vector3d> mu0, mu1;
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
      const std::size_t i = static_cast<std::size_t>(ii);
      LocalDeformation& r = out[i];
      r.lambda.setConstant(nan);
      r.strain.setConstant(nan);
      r.d2min = r.eps_q = nan;
      if (!indexed[i].allFinite()) continue;
      mu0.clear(), mu1.clear();
      grid.for_each_within(indexed[i], o.radius, [&](std::size_t k, double) {
        if (k == i) return;
        mu0.push_back(before[k] - before[i]);
        mu1.push_back(after[k] - after[i]);
      });
      r.neighbours = static_cast<std::uint32_t>(mu0.size());
      if (mu0.size() < o.min_neighbours) {
        r.status = DeformationStatus::too_few_neighbours;
        continue;
      }
      Eigen::Matrix3d lambda;
      double d2;
      if (!affine_fit(mu0, mu1, o.min_conditioning, lambda, d2)) {
        r.status = DeformationStatus::singular;
        continue;
      }
      r.status = DeformationStatus::ok;
      r.lambda = lambda;
      r.d2min = d2 * inv_d2;
      r.strain = local_strain(lambda);
      r.eps_q = deviatoric_strain(r.strain);
    }
  }
  return out;
}

TrackedStrains tracked_strains(const std::vector<double>& centroid, std::size_t tracks, std::size_t scans) {
  if (centroid.size() != tracks * scans * 3) throw UsageError("tracked_strains: the centroid table is not N x T x 3");
  TrackedStrains eps{std::vector<double>(scans, std::nan("")), std::vector<double>(scans, std::nan(""))};
  const auto at = [&](std::size_t i, std::size_t t) {
    const double* p = centroid.data() + 3 * (i * scans + t);
    return Eigen::Vector3d(p[0], p[1], p[2]);
  };
  for (std::size_t t = 0; t < scans; ++t) {
    std::vector<Eigen::Vector3d> before, after;
    Eigen::Vector3d mean_before = Eigen::Vector3d::Zero(), mean_after = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < tracks; ++i)
      if (at(i, 0).allFinite() && at(i, t).allFinite()) {
        before.push_back(at(i, 0)), after.push_back(at(i, t));
        mean_before += before.back(), mean_after += after.back();
      }
    if (before.size() < 4) continue;
    mean_before /= double(before.size()), mean_after /= double(after.size());
    for (std::size_t k = 0; k < before.size(); ++k) before[k] -= mean_before, after[k] -= mean_after;
    Eigen::Matrix3d lambda;
    double residual = 0.0;
    if (!affine_fit(before, after, 1e-9, lambda, residual)) continue;
    if (lambda(2, 2) > 0.0) eps.axial[t] = -std::log(lambda(2, 2));
    if (lambda.determinant() > 0.0) eps.volumetric[t] = -std::log(lambda.determinant());
  }
  return eps;
}

}  // namespace graintwin::micro
