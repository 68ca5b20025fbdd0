#pragma once
// Exact answers of a synthetic scan (kind=ground_truth): the label image, every grain's pose, size,
// SH shape and invariants, every contact or near-contact with its normal, point and overlap/gap,
// and the applied strain. Grain i has label i + 1 in every scan of a series, which is the true
// identity across scans. Layout: docs/formats.md.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/packing.hpp"
#include "graintwin/synth/solid_grains.hpp"

namespace graintwin::synth {

/// A true contact or near-contact between grains with labels low < high.
struct TrueContact {
  std::uint32_t low = 0, high = 0;
  double overlap = 0.0;               ///< m; > 0 interpenetration, < 0 gap
  Eigen::Vector3d point{0, 0, 0};     ///< m, world
  Eigen::Vector3d normal{0, 0, 0};    ///< unit, from low to high
  bool touching = false;              ///< |overlap| <= the packing tolerance
};

/// Every pair closer than `search_gap` (m), overlapping pairs included: find_contacts() (the
/// packer's contact search) with labels index + 1 and `touching` set for |overlap| <= tolerance.
/// With `separating` (ctsynth sets it for angular grains) each contact is re-measured by
/// separating_contact() within a quarter of the smaller grain's volume-equivalent radius: its
/// normal, and the smaller of the two overlaps (the kernel's overstates at sharp edges, the
/// separating one on non-convex patches such as a bump in a dent, where the local convex hulls
/// overlap more than the grains; neither understates). Smooth grains keep the kernel's contacts:
/// on rough SH sand the two normals differ by a median 4 degrees (90th percentile 11, 297 contacts
/// of a 2.4 mm cylinder), the kernel's being the local bump's and the separating one that of the
/// local hulls, and earlier accuracy figures were measured against the kernel's. Parallel and
/// deterministic (sorted by (low, high)).
/// Grains that are not star-shaped (`solids`, null or one per grain, null where the table is the
/// grain) are searched through their hulls; a contact on a hull is kept only where the solid is
/// there: within max(search_gap, 2 tolerance) inward of the contact point along the normal, so a
/// neighbour that touches the lid the hull puts over a pocket or a cavity is not in contact.
std::vector<TrueContact> true_contacts(const std::vector<const shape::RadialTable*>& shapes,
                                       const std::vector<PackedGrain>& poses, double search_gap,
                                       double tolerance, bool separating = false,
                                       const std::vector<const GrainSolid*>& solids = {});

/// A simulated test's stress-strain curve from the start of shearing, one entry per recorded step:
/// axial log strain ln(H0 / H), sigma_1 / sigma_3 and volumetric strain ln(V0 / V).
struct LoadingCurve {
  std::vector<double> axial_strain, stress_ratio, volumetric_strain;
};

/// Everything written to one truth_NNN.h5.
struct GroundTruth {
  int scan_index = 0;
  double axial_strain = 0.0;                 ///< compression positive: nominal, or a simulation's ln(H0 / H)
  double sample_height = 0.0;                ///< m, platen to platen
  double sample_radius = 0.0;                ///< m, initial (membrane inner radius before bulging)
  double solid_fraction = 0.0;               ///< grain volume / sample volume
  double void_ratio = 0.0;                   ///< void / solid inside the sample
  double contact_tolerance = 0.0;            ///< m
  Volume<std::uint32_t> labels;              ///< label of the grain containing each voxel centre
  std::vector<PackedGrain> poses;            ///< per grain
  std::vector<double> volume;                ///< m^3 per grain
  std::vector<double> equivalent_diameter;   ///< m
  std::vector<double> sphericity, aspect_ratio;
  int sh_degree = 0;
  Eigen::MatrixXd sh_coeffs;                 ///< N x (L+1)^2, world frame, about the centroid
  Eigen::MatrixXd sh_coeffs_body;            ///< N x (L+1)^2, body frame
  Eigen::MatrixXd sh_invariants;             ///< N x (L+1)
  std::vector<TrueContact> contacts;
  /// A simulated state's contact forces, one per contact (N, on `high`; zero where the pair carries
  /// none), its sigma_1 / sigma_3 and volumetric strain ln(V0 / V); empty and NaN for prescribed states.
  bool simulated = false;
  std::vector<Eigen::Vector3d> contact_force;
  double stress_ratio = std::numeric_limits<double>::quiet_NaN();
  double volumetric_strain = std::numeric_limits<double>::quiet_NaN();
  LoadingCurve loading_curve;                ///< simulated states: the whole test's curve (the same in every scan)
  /// Per grain: what a radial description misses of it (zeros for star-shaped grains).
  std::vector<NonStarMeasures> non_star;
};

void write_ground_truth(const std::filesystem::path& path, const GroundTruth& truth,
                        const std::vector<std::string>& history);

/// Reads a truth_NNN.h5 back into a GroundTruth (the non-star measures only when the file has them).
/// UsageError naming the file when it is not kind=ground_truth; DataError naming the file and the
/// dataset when its tables disagree in length or hold a value ctsynth never writes (NaN or infinity
/// in a position, volume, coefficient, normal or the loading curve).
GroundTruth read_ground_truth(const std::filesystem::path& path);

}  // namespace graintwin::synth
