#include "graintwin/synth/psd.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::synth {

namespace {
double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }
}  // namespace

void Psd::validate() const {
  if (!(d_min > 0.0 && d_min <= d50 && d50 <= d_max))
    throw UsageError(fmt::format("grain sizes must satisfy 0 < d-min <= d50 <= d-max (got {:g}, {:g}, {:g} mm); "
                                 "reorder --d-min, --d50 and --d-max",
                                 d_min * 1e3, d50 * 1e3, d_max * 1e3));
  if (!(sigma_ln > 0.0)) throw UsageError("psd-sigma must be positive (log-normal spread of the grading)");
}

double Psd::percent_passing(double d) const {
  if (d <= d_min) return 0.0;
  if (d >= d_max) return 100.0;
  const double lo = normal_cdf(std::log(d_min / d50) / sigma_ln), hi = normal_cdf(std::log(d_max / d50) / sigma_ln);
  return 100.0 * (normal_cdf(std::log(d / d50) / sigma_ln) - lo) / (hi - lo);
}

std::vector<double> sample_diameters(const Psd& psd, double target_volume, std::mt19937_64& rng) {
  psd.validate();
  // By number, a log-normal whose mass median is d50 has median d50 exp(-3 sigma^2); the truncation
  // bounds are the same by number and by mass. Sample by inverting the truncated CDF.
  const double mu = std::log(psd.d50) - 3.0 * psd.sigma_ln * psd.sigma_ln;
  const double lo = normal_cdf((std::log(psd.d_min) - mu) / psd.sigma_ln);
  const double hi = normal_cdf((std::log(psd.d_max) - mu) / psd.sigma_ln);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> d;
  double total = 0.0;
  while (total < target_volume) {
    // Inverse normal CDF by bisection on erfc: robust and fast enough for thousands of grains.
    const double p = u(rng);
    double a = -9.0, b = 9.0;
    for (int it = 0; it < 60; ++it) {
      const double m = 0.5 * (a + b);
      (normal_cdf(m) < p ? a : b) = m;
    }
    const double di = std::clamp(std::exp(mu + psd.sigma_ln * 0.5 * (a + b)), psd.d_min, psd.d_max);
    d.push_back(di);
    total += M_PI / 6.0 * di * di * di;
  }
  return d;
}

double expected_grain_count(const Psd& psd, double target_volume) {
  psd.validate();
  // ln d by number ~ N(mu, s^2) truncated to [ln d_min, ln d_max]; E[d^3] over the truncation is
  // exp(3 mu + 9 s^2 / 2) times the normal mass of the bounds shifted by 3 s, over their own mass.
  const double s = psd.sigma_ln, mu = std::log(psd.d50) - 3.0 * s * s;
  const double a = (std::log(psd.d_min) - mu) / s, b = (std::log(psd.d_max) - mu) / s;
  const double mass = normal_cdf(b) - normal_cdf(a);
  const double mean_d3 = mass > 0.0 ? std::exp(3.0 * mu + 4.5 * s * s) * (normal_cdf(b - 3.0 * s) - normal_cdf(a - 3.0 * s)) / mass
                                    : psd.d50 * psd.d50 * psd.d50;  // d_min = d_max: one size
  return target_volume / (M_PI / 6.0 * std::max(mean_d3, psd.d_min * psd.d_min * psd.d_min));
}

}  // namespace graintwin::synth
