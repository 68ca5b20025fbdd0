#include "graintwin/track/displacement_field.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
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

std::vector<double> right_pair_probability(std::vector<ResidualTerm>& terms, const std::vector<double>& start) {
  const std::size_t n = terms.empty() ? 0 : terms.front().value.size();
  for (const ResidualTerm& t : terms) {
    if (t.value.size() != n) throw UsageError("right_pair_probability: every term needs one value per pair");
    if (!(t.floor > 0.0)) throw UsageError("right_pair_probability: a term's floor must be positive");
  }
  if (!start.empty() && start.size() != n) throw UsageError("right_pair_probability: one starting probability per pair is needed");
  const bool from_start = std::accumulate(start.begin(), start.end(), 0.0) > 0.0;
  std::vector<double> right = from_start ? start : std::vector<double>(n, 1.0);
  if (n == 0) return right;
  // A wrong pair's log density in each term: uniform over the span of the values, at least ten
  // floors wide so that identical values do not make every pair look wrong.
  std::vector<double> log_wrong(terms.size());
  for (std::size_t k = 0; k < terms.size(); ++k) {
    ResidualTerm& t = terms[k];
    const auto [lo, hi] = std::minmax_element(t.value.begin(), t.value.end());
    t.spread = std::max(t.spread, t.floor);
    switch (t.law) {
      case ResidualLaw::length3: {
        const double r = std::max(*hi, 10.0 * t.floor);
        log_wrong[k] = std::log(3.0 / (r * r * r));  // of the length, per r^2 (shared with the right law)
        break;
      }
      case ResidualLaw::gaussian: log_wrong[k] = -std::log(std::max(*hi - *lo, 10.0 * t.floor)); break;
      case ResidualLaw::half_normal: log_wrong[k] = -std::log(std::max(*hi, 10.0 * t.floor)); break;
    }
  }
  const double log_sqrt_2pi = 0.5 * std::log(2.0 * std::numbers::pi);
  double share = 0.5;
  // Expectation: each pair's probability of being right. The right laws' log densities are
  // -z^2 / 2 plus a constant: Gaussian -ln(sqrt(2 pi) sigma), half-normal ln 2 more, Maxwell
  // (per r^2) ln 2 - 2 ln sigma more.
  const auto expectation = [&] {
    double log_odds = std::log(share / (1.0 - share));
    for (std::size_t k = 0; k < terms.size(); ++k) {
      const ResidualTerm& t = terms[k];
      log_odds += -std::log(t.spread) - log_sqrt_2pi - log_wrong[k];
      if (t.law == ResidualLaw::length3) log_odds += std::log(2.0) - 2.0 * std::log(t.spread);
      if (t.law == ResidualLaw::half_normal) log_odds += std::log(2.0);
    }
    for (std::size_t i = 0; i < n; ++i) {
      double log_ratio = log_odds;
      for (const ResidualTerm& t : terms) {
        const double z = (t.value[i] - (t.law == ResidualLaw::gaussian ? t.centre : 0.0)) / t.spread;
        log_ratio -= 0.5 * z * z;
      }
      right[i] = 1.0 / (1.0 + std::exp(-std::clamp(log_ratio, -700.0, 700.0)));
    }
  };
  for (int iteration = 0; iteration < 200; ++iteration) {
    if (iteration > 0 || !from_start) expectation();
    // Maximisation: the share and each term's centre and spread over the right pairs.
    const double sum = std::accumulate(right.begin(), right.end(), 0.0);
    const double new_share = std::clamp(sum / static_cast<double>(n), 1e-6, 1.0 - 1e-6);
    double change = std::abs(new_share - share);
    share = new_share;
    if (!(sum > 0.0)) break;
    for (ResidualTerm& t : terms) {
      if (t.law == ResidualLaw::gaussian) {
        double m = 0.0;
        for (std::size_t i = 0; i < n; ++i) m += right[i] * t.value[i];
        t.centre = m / sum;
      }
      const double c = t.law == ResidualLaw::gaussian ? t.centre : 0.0;
      double s2 = 0.0;
      for (std::size_t i = 0; i < n; ++i) s2 += right[i] * (t.value[i] - c) * (t.value[i] - c);
      const double spread = std::max(t.floor, std::sqrt(s2 / (sum * (t.law == ResidualLaw::length3 ? 3.0 : 1.0))));
      change = std::max(change, std::abs(spread - t.spread) / t.spread);
      t.spread = spread;
    }
    if (change < 1e-5) break;
  }
  return right;
}

Affine robust_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     double inlier_distance, int max_trials, std::uint64_t seed, std::vector<double>* weights) {
  if (from.size() != to.size()) throw UsageError("robust_affine: from and to must have the same length");
  if (!(inlier_distance > 0.0)) throw UsageError("robust_affine: the inlier distance must be positive");
  const std::size_t n = from.size();
  std::vector<double> w(n, 1.0), r(n);
  const auto residuals = [&](const Affine& f) {
    for (std::size_t i = 0; i < n; ++i) r[i] = (f(from[i]) - to[i]).norm();
  };
  const auto count_inliers = [&](const Affine& f) {
    std::size_t c = 0;
    for (std::size_t i = 0; i < n; ++i) c += (f(from[i]) - to[i]).norm() <= inlier_distance;
    return c;
  };
  Affine best = fit_affine(from, to);
  if (n >= 8) {
    // RANSAC: draw until a sample of four right pairs has come up with 99 % probability, were the
    // best inlier share found so far the share of right pairs (30 % right pairs: 560 draws).
    std::size_t best_count = count_inliers(best);
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    std::vector<Eigen::Vector3d> f4(4), t4(4);
    const auto draws_needed = [&] {
      const double clean = std::pow(static_cast<double>(best_count) / static_cast<double>(n), 4.0);
      return clean >= 1.0 ? 0.0 : clean <= 0.0 ? 1e300 : std::log(0.01) / std::log1p(-clean);
    };
    for (int t = 0; t < max_trials && t < draws_needed(); ++t) {
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
  // Refit weighted by each pair's probability of being right under the current map, starting
  // from the RANSAC inliers.
  std::vector<ResidualTerm> position{{ResidualLaw::length3, {}, inlier_distance / 4.0, 0.0, inlier_distance / 4.0}};
  for (int it = 0; it < 6 && n > 0; ++it) {
    residuals(best);
    position[0].value = r;
    w = right_pair_probability(position, w);
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
