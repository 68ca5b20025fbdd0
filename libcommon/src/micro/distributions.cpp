#include "graintwin/micro/distributions.hpp"

#include <gsl/gsl_sf_zeta.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"

namespace graintwin::micro {
namespace {

Histogram binned(const std::vector<double>& values, std::vector<double> edges, bool logarithmic) {
  Histogram h;
  const std::size_t bins = edges.size() - 1;
  h.count.assign(bins, 0);
  const double lo = edges.front(), hi = edges.back();
  const double a = logarithmic ? std::log(lo) : lo, width = ((logarithmic ? std::log(hi) : hi) - a) / double(bins);
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    if (v < lo || v > hi) {
      ++h.outside;
      continue;
    }
    const double u = ((logarithmic ? std::log(v) : v) - a) / width;
    std::size_t b = std::min(bins - 1, static_cast<std::size_t>(std::max(0.0, u)));
    // Rounding at an edge: keep the bin whose closed interval holds v.
    if (v < edges[b] && b > 0) --b;
    if (v > edges[b + 1] && b + 1 < bins) ++b;
    ++h.count[b];
    ++h.used;
  }
  h.density.resize(bins);
  for (std::size_t b = 0; b < bins; ++b)
    h.density[b] = h.used ? double(h.count[b]) / (double(h.used) * (edges[b + 1] - edges[b])) : 0.0;
  h.edges = std::move(edges);
  return h;
}

/// ln zeta(alpha, q); the callers keep 1 < alpha <= 10 and q >= 1, where GSL neither overflows nor
/// underflows for any cluster size a sample can have.
double log_hzeta(double alpha, double q) { return std::log(gsl_sf_hzeta(alpha, q)); }

std::vector<double> sorted_tail(const std::vector<double>& values, double x_min) {
  std::vector<double> t;
  for (double v : values)
    if (std::isfinite(v) && v >= x_min) t.push_back(v);
  std::sort(t.begin(), t.end());
  return t;
}

/// Largest distance between the empirical CDF of sorted `tail` and `cdf` (P(X <= x)), checked on
/// both sides of every step; for discrete data the steps are the distinct values.
template <class Cdf>
double ks_distance(const std::vector<double>& tail, Cdf cdf, bool discrete) {
  const double n = double(tail.size());
  double d = 0.0;
  for (std::size_t i = 0; i < tail.size();) {
    std::size_t j = i;
    while (j < tail.size() && tail[j] == tail[i]) ++j;
    const double model = cdf(tail[i]);
    d = std::max(d, std::abs(double(j) / n - model));
    if (!discrete) d = std::max(d, std::abs(double(i) / n - model));
    i = j;
  }
  return d;
}

}  // namespace

Histogram linear_histogram(const std::vector<double>& values, double lo, double hi, std::size_t bins) {
  if (!(lo < hi) || bins == 0) throw UsageError("linear_histogram: needs lo < hi and at least one bin");
  std::vector<double> edges(bins + 1);
  for (std::size_t b = 0; b <= bins; ++b) edges[b] = lo + (hi - lo) * double(b) / double(bins);
  return binned(values, std::move(edges), false);
}

Histogram log_histogram(const std::vector<double>& values, double lo, double hi, double per_decade) {
  if (!(lo > 0.0) || !(lo < hi) || !(per_decade > 0.0))
    throw UsageError("log_histogram: needs 0 < lo < hi and a positive number of bins per decade");
  const std::size_t bins = std::max<std::size_t>(1, std::size_t(std::ceil(std::log10(hi / lo) * per_decade - 1e-9)));
  std::vector<double> edges(bins + 1);
  const double step = std::log10(hi / lo) / double(bins);
  for (std::size_t b = 0; b <= bins; ++b) edges[b] = lo * std::pow(10.0, step * double(b));
  edges.back() = hi;
  return binned(values, std::move(edges), true);
}

Histogram log_histogram_auto(const std::vector<double>& values, double per_decade) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (double v : values)
    if (std::isfinite(v) && v > 0.0) lo = std::min(lo, v), hi = std::max(hi, v);
  if (!(hi > lo)) return {};
  // Whole bins on a grid of 1/per_decade decades, so PDFs of different states share edges.
  const double a = std::floor(std::log10(lo) * per_decade) / per_decade, b = std::ceil(std::log10(hi) * per_decade) / per_decade;
  return log_histogram(values, std::pow(10.0, a), std::pow(10.0, b > a ? b : a + 1.0 / per_decade), per_decade);
}

PowerLawFit fit_power_law_continuous(const std::vector<double>& values, double x_min) {
  PowerLawFit f;
  f.x_min = x_min;
  if (!(x_min > 0.0)) return f;
  const std::vector<double> tail = sorted_tail(values, x_min);
  double sum = 0.0;
  for (double v : tail) sum += std::log(v / x_min);
  f.tail = tail.size();
  if (tail.size() < 2 || !(sum > 0.0)) return f;
  const double n = double(tail.size());
  f.alpha = 1.0 + n / sum;
  f.alpha_error = (f.alpha - 1.0) / std::sqrt(n);
  f.ks = ks_distance(tail, [&](double x) { return 1.0 - std::pow(x / x_min, 1.0 - f.alpha); }, false);
  f.valid = true;
  return f;
}

PowerLawFit fit_power_law_discrete(const std::vector<double>& values, double s_min) {
  PowerLawFit f;
  f.x_min = s_min;
  if (!(s_min >= 1.0)) return f;
  const std::vector<double> tail = sorted_tail(values, s_min);
  double sum_log = 0.0;
  for (double v : tail) sum_log += std::log(v);
  f.tail = tail.size();
  if (tail.size() < 2 || tail.front() == tail.back()) return f;
  const double n = double(tail.size());
  // Negative log-likelihood per value; convex in alpha (ln zeta is a log-partition function).
  const auto nll = [&](double a) { return log_hzeta(a, s_min) + a * sum_log / n; };
  double lo = 1.0 + 1e-6, hi = 10.0;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo), f1 = nll(x1), f2 = nll(x2);
  while (hi - lo > 1e-9) {
    if (f1 < f2) hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = nll(x1);
    else lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = nll(x2);
  }
  f.alpha = 0.5 * (lo + hi);
  const double h = 1e-3;
  const double curvature = (log_hzeta(f.alpha + h, s_min) - 2.0 * log_hzeta(f.alpha, s_min) + log_hzeta(f.alpha - h, s_min)) / (h * h);
  f.alpha_error = curvature > 0.0 ? 1.0 / std::sqrt(n * curvature) : std::numeric_limits<double>::quiet_NaN();
  const double log_norm = log_hzeta(f.alpha, s_min);
  f.ks = ks_distance(tail, [&](double s) { return 1.0 - std::exp(log_hzeta(f.alpha, s + 1.0) - log_norm); }, true);
  f.valid = std::isfinite(f.alpha) && std::isfinite(f.ks);
  return f;
}

PowerLawFit fit_power_law(const std::vector<double>& values, bool discrete, std::size_t min_tail) {
  std::vector<double> v = sorted_tail(values, discrete ? 1.0 : std::numeric_limits<double>::min());
  PowerLawFit best;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i > 0 && v[i] == v[i - 1]) continue;
    if (v.size() - i < std::max<std::size_t>(min_tail, 2)) break;
    const PowerLawFit f = discrete ? fit_power_law_discrete(v, v[i]) : fit_power_law_continuous(v, v[i]);
    if (f.valid && (!best.valid || f.ks < best.ks)) best = f;
  }
  return best;
}

ExponentialFit fit_exponential(const std::vector<double>& values, double x0) {
  ExponentialFit f;
  f.x0 = x0;
  double sum = 0.0;
  for (double v : values)
    if (std::isfinite(v) && v >= x0) sum += v - x0, ++f.count;
  if (f.count < 2 || !(sum > 0.0)) return f;
  f.scale = sum / double(f.count);
  f.scale_error = f.scale / std::sqrt(double(f.count));
  f.valid = true;
  return f;
}

LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw UsageError("fit_line: x and y differ in length");
  LineFit f;
  double sx = 0.0, sy = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) sx += x[i], sy += y[i], ++n;
  f.count = n;
  if (n < 3) return f;
  const double mx = sx / double(n), my = sy / double(n);
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  if (!(sxx > 0.0)) return f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  double rss = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) {
      const double r = y[i] - f.intercept - f.slope * x[i];
      rss += r * r;
    }
  const double s2 = rss / double(n - 2);
  f.slope_error = std::sqrt(s2 / sxx);
  f.intercept_error = std::sqrt(s2 * (1.0 / double(n) + mx * mx / sxx));
  f.valid = true;
  return f;
}

}  // namespace graintwin::micro
