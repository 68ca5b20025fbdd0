#pragma once
// Distributions of per-grain quantities: histograms with linear or logarithmic bins normalised
// to probability densities, maximum-likelihood power-law fits (Clauset, Shalizi and Newman 2009,
// SIAM Review 51, 661), exponential fits, and straight-line least squares with standard errors.
#include <cstdint>
#include <vector>

namespace graintwin::micro {

/// A histogram normalised as a probability density: density[b] = count[b] / (n_used * width[b]),
/// so sum density * width = 1 over the values that fell in the bins.
struct Histogram {
  std::vector<double> edges;           ///< bins + 1, increasing
  std::vector<std::uint64_t> count;    ///< bins
  std::vector<double> density;         ///< bins, 1 / (unit of the values)
  std::uint64_t used = 0;              ///< finite values inside [edges.front(), edges.back()]
  std::uint64_t outside = 0;           ///< finite values outside (below or above every bin)
};

/// `bins` equal bins over [lo, hi] (lo < hi; the last bin includes hi). NaN values are skipped.
Histogram linear_histogram(const std::vector<double>& values, double lo, double hi, std::size_t bins);
/// Equal bins in log10 over [lo, hi] with `per_decade` bins per decade (0 < lo < hi). The
/// density is per unit of the value (not per decade), as a power law is usually plotted.
Histogram log_histogram(const std::vector<double>& values, double lo, double hi, double per_decade);
/// log_histogram over the positive finite values' own range (widened to whole bins); empty
/// histogram (no edges) when there are fewer than two distinct positive values.
Histogram log_histogram_auto(const std::vector<double>& values, double per_decade);

/// P(x) ~ x^-alpha for x >= x_min, fitted by maximum likelihood.
struct PowerLawFit {
  double alpha = 0.0;        ///< exponent
  double alpha_error = 0.0;  ///< one standard error (asymptotic, from the likelihood's curvature)
  double x_min = 0.0;        ///< lower bound of the power-law tail
  double ks = 0.0;           ///< Kolmogorov-Smirnov distance of the tail to the fit
  std::size_t tail = 0;      ///< values >= x_min used in the fit
  bool valid = false;        ///< false when fewer than `min_tail` values (or no variation) remain
};

/// Continuous power law with x_min given: alpha = 1 + n / sum ln(x / x_min), error (alpha - 1)/sqrt(n).
PowerLawFit fit_power_law_continuous(const std::vector<double>& values, double x_min);
/// Discrete power law on integers >= 1 with s_min given: P(s) = s^-alpha / zeta(alpha, s_min),
/// alpha maximising the likelihood (Hurwitz zeta from GSL), error 1/sqrt(-d2 lnL / d alpha^2).
PowerLawFit fit_power_law_discrete(const std::vector<double>& values, double s_min);
/// Clauset-Shalizi-Newman: every distinct value (with at least `min_tail` values at or above
/// it) is tried as x_min; the one whose fit has the smallest KS distance wins.
PowerLawFit fit_power_law(const std::vector<double>& values, bool discrete, std::size_t min_tail = 10);

/// P(x) = exp(-(x - x0) / scale) / scale for x >= x0 (maximum likelihood: scale = mean - x0);
/// the error is scale / sqrt(n).
struct ExponentialFit {
  double scale = 0.0, scale_error = 0.0, x0 = 0.0;
  std::size_t count = 0;
  bool valid = false;
};
ExponentialFit fit_exponential(const std::vector<double>& values, double x0);

/// y = intercept + slope x by least squares, with the standard errors of both.
struct LineFit {
  double slope = 0.0, intercept = 0.0, slope_error = 0.0, intercept_error = 0.0;
  std::size_t count = 0;
  bool valid = false;  ///< at least 3 points with distinct x
};
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace graintwin::micro
