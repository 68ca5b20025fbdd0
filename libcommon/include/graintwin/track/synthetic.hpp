#pragma once
// Synthetic grain tables with known identities for testing and timing the matchers without
// images: a dense random arrangement of grains (centroids, volumes, SH invariant spectra drawn the
// way ctsynth draws sand: all degrees tied to one random value), and a deformed copy under axial
// compression with bulging, a shear band with a smooth slip profile, nonaffine noise, measurement
// noise on volumes and invariants, grains removed or added, and grains the segmentation of the
// deformed scan damaged: touching pairs merged into one label, grains cut into two.
#include <array>
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
  /// Share of the grains that the deformed scan's segmentation merges with their nearest free
  /// neighbour (within 1.5 d50), two grains to one label: volume the sum, centroid the
  /// volume-weighted mean, invariants those of the two grains' bodies (balls of their volumes)
  /// joined at a point, seen from the joint centroid.
  double merged = 0.0;
  /// Share of the grains that it cuts in two by a random plane (0 to 0.5 of the body's radius off
  /// its centre): two labels whose volumes, centroids and invariants are those of the two pieces
  /// of the grain's body.
  double cut = 0.0;
  std::uint64_t seed = 2;
};

/// What the deformed scan's segmentation made of a reference grain.
enum class Segmented { intact, missing, merged, cut };

/// A deformed scan with its truth.
struct DeformedScan {
  ScanGrains grains;  ///< in a shuffled order, so that indices carry no identity
  /// Per reference grain: the index of its one label in the deformed scan when it is intact (the
  /// one-to-one partner a matcher should find), else -1 (missing, merged or cut).
  std::vector<int> partner;
  std::vector<Segmented> fate;  ///< per reference grain
  /// Per deformed-scan grain: the reference grains it holds (-1 = none): one for an intact grain
  /// or a piece of a cut one, two for a merged label, none for a newcomer.
  std::vector<std::array<int, 2>> source;
  /// True when deformed-scan grain j holds (part of) reference grain i.
  bool holds(std::size_t j, std::size_t i) const;
  /// True when deformed-scan grain j is a merged label or a piece of a cut grain.
  bool damaged(std::size_t j) const;
};

/// The deformed scan of `ref` under `motion`. UsageError for shares outside [0, 1] or adding up
/// to more than 1 (missing + merged + cut).
DeformedScan deform_scan(const ScanGrains& ref, const SyntheticMotion& motion);

/// A matching of a reference scan to its DeformedScan, scored against the truth.
struct SyntheticScore {
  /// Reference grains intact in the deformed scan: matched to their one label, to another, or lost.
  std::size_t intact = 0, right = 0, wrong = 0, lost = 0;
  /// Reference grains merged or cut: lost (right), matched to a label holding part of them (own),
  /// or to a label of other grains only (wrong), of which `stolen` are intact grains' labels.
  std::size_t damaged = 0, damaged_lost = 0, damaged_own = 0, damaged_wrong = 0, stolen = 0;
};
SyntheticScore score_matching(const DeformedScan& truth, const Matching& m);

/// The deformed scan alone; truth (size ref.size()) receives DeformedScan::partner.
ScanGrains deform_grains(const ScanGrains& ref, const SyntheticMotion& motion, std::vector<int>& truth);

}  // namespace graintwin::track
