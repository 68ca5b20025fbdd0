#pragma once
// Particle size distributions for synthetic samples: a truncated log-normal by mass (percent
// passing by volume), the way sand gradings are reported, sampled by number.
#include <random>
#include <vector>

namespace graintwin::synth {

/// Grain sizes as volume-equivalent diameters (m). By mass, log(d) is normal with median `d50`
/// and standard deviation `sigma_ln`, truncated to [d_min, d_max]. Default: Ottawa sand of the
/// reference experiment (docs/methods.md: 0.30-1.03 mm, d50 0.551 mm).
struct Psd {
  double d_min = 0.30e-3;
  double d50 = 0.551e-3;
  double d_max = 1.03e-3;
  double sigma_ln = 0.25;
  /// Throws UsageError unless 0 < d_min <= d50 <= d_max and sigma_ln > 0.
  void validate() const;
  /// Percent passing by volume at diameter d (0..100), the grading curve.
  double percent_passing(double d) const;
};

/// Draws diameters (number-weighted, so that the volume-weighted median is d50) until their total
/// sphere-equivalent volume reaches `target_volume` (m^3). Deterministic for a given rng state.
std::vector<double> sample_diameters(const Psd& psd, double target_volume, std::mt19937_64& rng);

/// The number of grains sample_diameters() draws on average to fill `target_volume` (m^3): the
/// volume over the mean sphere volume of the truncated log-normal by number. Lets a caller check
/// what a sample will cost before drawing it.
double expected_grain_count(const Psd& psd, double target_volume);

}  // namespace graintwin::synth
