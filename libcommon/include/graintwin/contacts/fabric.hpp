#pragma once
// Fabric of a contact network (docs/methods.md, fabric): second-order fabric tensors of directions
// (contact normals, branch vectors) with principal values and directions, the degree of
// anisotropy a of a distribution symmetric about z, rose-diagram counts per direction bin, and
// coordination numbers. Directions are axial: d and -d are the same direction.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/core/volume.hpp"
#include "graintwin/segment/labels.hpp"

namespace graintwin::contacts {

struct Fabric {
  std::size_t count = 0;                             ///< directions used (zero vectors are skipped)
  Eigen::Matrix3d tensor = Eigen::Matrix3d::Zero();  ///< phi_ij = (1/N) sum d_i d_j over unit d, (x, y, z)
  Vec3 principal_values{kNaN, kNaN, kNaN};           ///< phi_1 >= phi_2 >= phi_3 (sum 1)
  /// Column k: unit direction of phi_k, signed so that its z component is >= 0.
  Eigen::Matrix3d principal_directions = Eigen::Matrix3d::Constant(kNaN);
  double anisotropy = kNaN;                          ///< a, see anisotropy(); NaN when count = 0
};

/// The fabric tensor of `directions` ((x, y, z), any length; each is normalised, zero vectors are
/// skipped), its principal values and directions, and a.
Fabric fabric_tensor(const std::vector<Vec3>& directions);

/// Degree of anisotropy of a fabric tensor phi (trace 1) for a distribution symmetric about z,
/// E(gamma) = 3 (1 + a cos 2 gamma) / (4 pi (3 - a)) with gamma the angle from z, fitted by least
/// squares (docs/methods.md, membrane paper eqs. 31-41):
///   a = 15 (phi_xx + phi_yy - 2 phi_zz) / (-8 + 5 phi_xx + 5 phi_yy - 10 phi_zz).
/// a = 0 for an isotropic fabric, a > 0 when directions gather about z; a > 1 (phi_zz > 0.6) is
/// beyond what E(gamma) can describe with a non-negative density.
double anisotropy(const Eigen::Matrix3d& phi);

/// Direction counts for rose diagrams. Each direction is folded onto the upper hemisphere (d and -d
/// are one axis) and binned by polar angle theta from +z and azimuth phi from +x (towards +y).
struct Rose {
  std::vector<double> theta_edges;    ///< rad, n_theta + 1 edges over [0, pi/2]
  std::vector<double> phi_edges;      ///< rad, n_phi + 1 edges over [0, 2 pi]
  std::vector<std::uint64_t> counts;  ///< n_theta x n_phi, row-major (theta slowest)
  /// Directions per steradian over the whole sphere with each axis counted at d and -d:
  /// counts / (2 N solid angle of the bin); an isotropic set gives 1 / (4 pi) everywhere, directly
  /// comparable with E(gamma).
  std::vector<double> density;
};

/// Bins `directions` (zero vectors skipped). theta_bins, phi_bins >= 1 (UsageError otherwise).
Rose rose(const std::vector<Vec3>& directions, int theta_bins, int phi_bins);

/// Coordination numbers: Z_i = number of contacts of grain i.
struct Coordination {
  std::vector<std::uint32_t> per_grain;  ///< Z of grains[k], for every grain
  std::vector<std::uint64_t> histogram;  ///< histogram[z]: counted grains with Z = z
  double mean = kNaN;                    ///< mean Z of the counted grains
  std::size_t counted = 0;               ///< grains in the histogram and the mean
};

/// Z for every grain of `grains` (sorted by label) from `contacts`. The histogram and the mean
/// count only grains that do not touch the edge of the volume (their neighbours beyond it are
/// missing) unless `include_edge_grains`. A contact label without a row is a DataError.
Coordination coordination(const std::vector<segment::GrainRecord>& grains, const std::vector<Contact>& contacts,
                          bool include_edge_grains = false);

}  // namespace graintwin::contacts
