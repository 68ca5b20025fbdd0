#include "graintwin/track/displacement_field.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"

namespace graintwin::track {
namespace {

double weight_at(const std::vector<double>& w, std::size_t i) { return w.empty() ? 1.0 : w[i]; }

}  // namespace

Affine fit_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                  const std::vector<double>& weight) {
  if (from.size() != to.size() || (!weight.empty() && weight.size() != from.size()))
    throw UsageError("fit_affine: from, to and weight must have the same length");
  double sw = 0.0;
  std::size_t used = 0;
  Eigen::Vector3d mx = Eigen::Vector3d::Zero(), my = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double w = weight_at(weight, i);
    if (!(w > 0.0)) continue;
    sw += w, ++used;
    mx += w * from[i], my += w * to[i];
  }
  Affine f;
  if (used == 0) return f;
  mx /= sw, my /= sw;
  Eigen::Matrix3d cxx = Eigen::Matrix3d::Zero(), cyx = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double w = weight_at(weight, i);
    if (!(w > 0.0)) continue;
    const Eigen::Vector3d dx = from[i] - mx;
    cxx += w * dx * dx.transpose();
    cyx += w * (to[i] - my) * dx.transpose();
  }
  // The points must span 3-D: the smallest principal spread above 1e-4 of the largest.
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cxx, Eigen::EigenvaluesOnly).eigenvalues();
  if (used >= 4 && ev[0] > 1e-8 * ev[2] && ev[2] > 0.0) f.a = cyx * cxx.inverse();
  f.b = my - f.a * mx;
  return f;
}

Affine robust_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     double inlier_distance, int trials, std::uint64_t seed, std::vector<double>* weights) {
  if (from.size() != to.size()) throw UsageError("robust_affine: from and to must have the same length");
  if (!(inlier_distance > 0.0)) throw UsageError("robust_affine: the inlier distance must be positive");
  const std::size_t n = from.size();
  std::vector<double> w(n, 1.0);
  const auto count_inliers = [&](const Affine& f) {
    std::size_t c = 0;
    for (std::size_t i = 0; i < n; ++i) c += (f(from[i]) - to[i]).norm() <= inlier_distance;
    return c;
  };
  Affine best = fit_affine(from, to);
  if (n >= 8) {
    // RANSAC: a wrong-match rate of even 50 % leaves a clean 4-sample in 1 draw of 16.
    std::size_t best_count = count_inliers(best);
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    std::vector<Eigen::Vector3d> f4(4), t4(4);
    for (int t = 0; t < trials; ++t) {
      std::size_t idx[4];
      for (int k = 0; k < 4; ++k) {
        bool repeat = true;
        while (repeat) {
          idx[k] = pick(rng);
          repeat = std::find(idx, idx + k, idx[k]) != idx + k;
        }
        f4[static_cast<std::size_t>(k)] = from[idx[k]], t4[static_cast<std::size_t>(k)] = to[idx[k]];
      }
      const Affine f = fit_affine(f4, t4);
      const std::size_t c = count_inliers(f);
      if (c > best_count) best = f, best_count = c;
    }
    for (std::size_t i = 0; i < n; ++i) w[i] = (best(from[i]) - to[i]).norm() <= inlier_distance ? 1.0 : 0.0;
    best = fit_affine(from, to, w);
  }
  // IRLS with Tukey's biweight; the median norm of a 3-D Gaussian residual is 1.538 sigma.
  std::vector<double> r(n);
  for (int it = 0; it < 6 && n > 0; ++it) {
    for (std::size_t i = 0; i < n; ++i) r[i] = (best(from[i]) - to[i]).norm();
    const double sigma = std::max(median(r) / 1.538, inlier_distance / 4.0);
    const double c = 4.685 * sigma;
    for (std::size_t i = 0; i < n; ++i) {
      const double u = r[i] / c;
      w[i] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
    best = fit_affine(from, to, w);
  }
  if (weights) *weights = w;
  return best;
}

DisplacementField::DisplacementField(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                                     const std::vector<double>& weight, const Affine& base, double radius)
    : base_(base), radius_(radius), grid_(from, radius / 2.0) {
  if (from.size() != to.size() || (!weight.empty() && weight.size() != from.size()))
    throw UsageError("DisplacementField: from, to and weight must have the same length");
  if (!(radius > 0.0)) throw UsageError("DisplacementField: the radius must be positive");
  residual_.resize(from.size());
  weight_.resize(from.size());
  for (std::size_t i = 0; i < from.size(); ++i) {
    residual_[i] = to[i] - base(from[i]);
    weight_[i] = weight_at(weight, i);
  }
}

DisplacementField::Estimate DisplacementField::estimate(const Eigen::Vector3d& x, std::size_t exclude,
                                                       const std::vector<double>* errors, double clip) const {
  if (errors && errors->size() != residual_.size())
    throw UsageError("DisplacementField::estimate: one error per known pair is needed");
  // Unknowns: the residual at x (t) and its gradient times the radius (rows 1-3), for the three
  // components at once. A prior pseudo-pair of zero residual at x (weight 1) fades the correction
  // out where few pairs are near, and a ridge on the gradient keeps coplanar neighbours stable.
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 3> rhs = Eigen::Matrix<double, 4, 3>::Zero();
  Estimate out;
  double sum_e2 = 0.0;
  const double r2 = radius_ * radius_, c2 = clip * clip;
  grid_.for_each_within(x, radius_, [&](std::size_t a, double d2) {
    if (a == exclude || !(weight_[a] > 0.0)) return;
    const double u = 1.0 - d2 / r2;
    const double k = weight_[a] * u * u;
    Eigen::Vector4d v;
    v << 1.0, (grid_.point(a) - x) / radius_;
    m.noalias() += k * v * v.transpose();
    rhs.noalias() += k * v * residual_[a].transpose();
    if (errors) sum_e2 += k * std::min((*errors)[a] * (*errors)[a], c2) / 3.0;
  });
  out.weight = m(0, 0);
  out.spread = out.weight > 0.0 ? std::sqrt(sum_e2 / out.weight) : 0.0;
  m(0, 0) += 1.0;
  const double ridge = 0.1 * m(0, 0);
  for (int k = 1; k < 4; ++k) m(k, k) += ridge;
  const Eigen::Matrix<double, 4, 3> sol = m.ldlt().solve(rhs);
  out.position = base_(x) + sol.row(0).transpose();
  return out;
}

}  // namespace graintwin::track
