#include "graintwin/micro/forces.hpp"

#include <gsl/gsl_cdf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "graintwin/contacts/fabric.hpp"
#include "graintwin/core/error.hpp"

namespace graintwin::micro {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Index of the bin of sorted `edges` holding v (the last bin includes the top edge).
std::size_t bin_of(const std::vector<double>& edges, double v) {
  const auto it = std::upper_bound(edges.begin(), edges.end(), v);
  const std::size_t k = it == edges.begin() ? 0 : std::size_t(it - edges.begin()) - 1;
  return std::min(k, edges.size() - 2);
}
}  // namespace

WeakForceFit fit_weak_forces(const std::vector<double>& f) {
  WeakForceFit w;
  double sum = 0.0;
  for (double v : f)
    if (std::isfinite(v) && v > 0.0 && v < 1.0) sum += std::log(v), ++w.count;
  if (w.count < 2 || !(sum < 0.0)) return w;
  const double n = double(w.count);
  w.theta = -1.0 - n / sum;
  w.theta_error = (w.theta + 1.0) / std::sqrt(n);
  w.valid = true;
  return w;
}

ForceDistribution force_distribution(const std::vector<double>& fn, double per_decade) {
  ForceDistribution d;
  std::vector<double> positive;
  for (double v : fn)
    if (std::isfinite(v) && v > 0.0) positive.push_back(v);
  if (positive.empty()) return d;
  for (double v : positive) d.mean += v;
  d.mean /= double(positive.size());
  for (double v : positive) d.normalised.push_back(v / d.mean);
  d.pdf = log_histogram_auto(d.normalised, per_decade);
  d.strong = fit_exponential(d.normalised, 1.0);
  d.weak = fit_weak_forces(d.normalised);
  return d;
}

ForceRose force_rose(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& fn, int theta_bins, int phi_bins) {
  if (normals.size() != fn.size()) throw UsageError("force_rose: one normal force per normal is needed");
  std::vector<Vec3> dirs;
  std::vector<std::size_t> kept;
  for (std::size_t c = 0; c < normals.size(); ++c)
    if (normals[c].allFinite() && normals[c].squaredNorm() > 0.0 && std::isfinite(fn[c]))
      dirs.push_back({normals[c].x(), normals[c].y(), normals[c].z()}), kept.push_back(c);
  const contacts::Rose counts = contacts::rose(dirs, theta_bins, phi_bins);
  ForceRose r;
  r.theta_edges = counts.theta_edges, r.phi_edges = counts.phi_edges, r.counts = counts.counts;
  const std::size_t np = std::size_t(phi_bins);
  std::vector<double> sum(r.counts.size(), 0.0);
  for (std::size_t c : kept) {
    Eigen::Vector3d n = normals[c].normalized();
    if (n.z() < 0.0) n = -n;  // one axis: the upper hemisphere, as contacts::rose folds it
    const double theta = std::acos(std::min(1.0, n.z()));
    double phi = n.x() == 0.0 && n.y() == 0.0 ? 0.0 : std::atan2(n.y(), n.x());
    if (phi < 0.0) phi += 2.0 * std::numbers::pi;
    sum[bin_of(r.theta_edges, theta) * np + bin_of(r.phi_edges, phi)] += fn[c];
  }
  r.mean_force.resize(sum.size());
  for (std::size_t b = 0; b < sum.size(); ++b) r.mean_force[b] = r.counts[b] ? sum[b] / double(r.counts[b]) : kNaN;
  return r;
}

double deviatoric_stress_q(const Eigen::Matrix3d& stress) {
  const Eigen::Matrix3d sym = 0.5 * (stress + stress.transpose());
  const Eigen::Matrix3d s = sym - sym.trace() / 3.0 * Eigen::Matrix3d::Identity();
  return std::sqrt(0.5 * s.cwiseProduct(s).sum());
}

double volatility(const std::vector<double>& q) {
  std::vector<double> ret;
  for (std::size_t i = 1; i < q.size(); ++i) {
    if (!(q[i] > 0.0) || !(q[i - 1] > 0.0)) return kNaN;
    ret.push_back(std::log(q[i] / q[i - 1]));
  }
  if (ret.size() < 2) return kNaN;
  double mean = 0.0;
  for (double v : ret) mean += v;
  mean /= double(ret.size());
  double ss = 0.0;
  for (double v : ret) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / double(ret.size() - 1));
}

Correlation pearson(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw UsageError("pearson: x and y differ in length");
  Correlation c;
  double sx = 0.0, sy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) sx += x[i], sy += y[i], ++c.count;
  if (c.count < 3) return {kNaN, kNaN, c.count};
  const double mx = sx / double(c.count), my = sy / double(c.count);
  double sxx = 0.0, syy = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i]))
      sxx += (x[i] - mx) * (x[i] - mx), syy += (y[i] - my) * (y[i] - my), sxy += (x[i] - mx) * (y[i] - my);
  if (!(sxx > 0.0) || !(syy > 0.0)) return {kNaN, kNaN, c.count};
  c.r = std::clamp(sxy / std::sqrt(sxx * syy), -1.0, 1.0);
  const double dof = double(c.count - 2);
  if (std::abs(c.r) >= 1.0) {
    c.p_value = 0.0;
    return c;
  }
  const double t = c.r * std::sqrt(dof / (1.0 - c.r * c.r));
  c.p_value = 2.0 * gsl_cdf_tdist_Q(std::abs(t), dof);
  return c;
}

}  // namespace graintwin::micro
