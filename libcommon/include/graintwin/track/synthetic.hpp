#pragma once
// Synthetic grain tables with known identities for testing and timing the matchers without
// images: a dense random arrangement of grains (centroids, volumes, SH invariant spectra drawn the
// way ctsynth draws sand: all degrees tied to one random value), and a deformed copy under axial
// compression with bulging, a shear band with a smooth slip profile, nonaffine noise, measurement
// noise on volumes and invariants, and grains removed or added.
#include <cstdint>
#include <vector>

#include "graintwin/track/match.hpp"

namespace graintwin::track {

/// n grains about d50 across (log-normal sizes, sigma 0.25) on a jittered cubic lattice at the
/// number density of a dense sand packing, in a box with its base at z = 0; invariants to degree
/// `degree`. Deterministic for a seed.
ScanGrains synthetic_grains(std::size_t n, double d50, int degree = 15, std::uint64_t seed = 1);

struct SyntheticMotion {
  double axial_strain = 0.02;   ///< compression along z, about the base z = 0
  double bulge = 0.5;           ///< lateral strain / axial strain, about the box's vertical axis
  double band_slip_d50 = 0.0;   ///< slip across the shear band (d50), x direction, band plane at 60 degrees
  double band_width_d50 = 4.0;  ///< width of the erf slip profile (d50)
  double noise_d50 = 0.02;      ///< nonaffine motion, standard deviation per component (d50)
  double volume_noise = 0.01;   ///< relative standard deviation of the measured volume
  double shape_noise = 0.01;    ///< standard deviation of each invariant, relative to ||R_0||
  double missing = 0.0;         ///< share of grains absent from the deformed scan
  double extra = 0.0;           ///< share of new grains (random size and place) in the deformed scan
  std::uint64_t seed = 2;
};

/// The deformed scan, its grains in a shuffled order. truth (size ref.size()) receives the index
/// of each reference grain in the deformed scan, or -1 if it went missing.
ScanGrains deform_grains(const ScanGrains& ref, const SyntheticMotion& motion, std::vector<int>& truth);

}  // namespace graintwin::track
