#pragma once
// The statistically equivalent sample: instead of the scan's own arrangement, grains
// drawn from the shape library (the grains of a shapes file, SH surfaces about their centroids)
// packed at random positions and orientations into a cylinder at a chosen solid fraction, by the
// synthetic-scan packer (synth::pack_in_stages: grown smooth, then with their true roughness).
// Drawing every library grain once keeps the library's PSD exactly; drawing N grains with
// replacement keeps it in expectation. The container's volume is the drawn grains' volume over the
// solid fraction, so the sample has that solid fraction by construction (if it packs: rough sand
// jams near 0.58 in cylinders a few d50 across, synth/packing.hpp).
#include <cstdint>
#include <functional>
#include <vector>

#include "graintwin/mesh/tet_mesh.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::mesh {

struct EquivalentPackingOptions {
  std::size_t grains = 0;       ///< grains in the sample; 0: every usable library grain once
  double solid_fraction = 0.0;  ///< drawn grain volume / cylinder volume, in (0, synth::kDensestPacking]
  double aspect = 1.0;          ///< cylinder height / diameter (> 0)
  /// SH degrees of the smoothed stages packed first, increasing; those not below the library's
  /// degree are left out.
  std::vector<int> smooth_degrees{4, 8};
  std::uint64_t seed = 1;
  int table_nodes = 48;         ///< cube-map nodes per face edge of the packer's radius tables
};

struct EquivalentSample {
  std::vector<std::size_t> source;        ///< library index of every sample grain
  std::vector<synth::PackedGrain> poses;  ///< centroid position and body -> world rotation, m
  synth::Container container;             ///< cylinder, axis z through x = y = 0, z from 0 to height
  synth::PackingReport report;
  std::size_t unusable = 0;               ///< library grains left out (SH fit unreliable or r <= 0 somewhere)
  shape::SizeDistribution psd;            ///< of the drawn grains (their SH volumes)
};

/// Draws and packs the sample from `library` (SH coefficients of degree `degree` about each
/// grain's centroid). Deterministic for a seed. UsageError for options out of range, DataError when
/// no library grain is usable or the grains do not pack (the packer's message). `observe` gets the
/// packing's status after every sweep (synth::pack_in_stages).
EquivalentSample pack_equivalent_sample(const std::vector<const shape::GrainShape*>& library, int degree,
                                        const EquivalentPackingOptions& options,
                                        const synth::PackingObserver& observe = {});

/// Moves a mesh made about the grain's body origin (its centroid at 0) to its pose in the sample.
void place_mesh(TetMesh& mesh, const synth::PackedGrain& pose);

}  // namespace graintwin::mesh
