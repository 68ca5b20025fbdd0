#pragma once
// Contacts between labelled grains (docs/methods.md, contacts and normals). Grains i < j touch when a voxel of i and a
// voxel of j are neighbours in the 26-neighbourhood; the contact voxels of the pair are the voxels
// of i that neighbour j and the voxels of j that neighbour i. All contact regions of one pair form
// one contact. One raster pass gathers exact integer sums per pair, from which come the PCA normal,
// the centroid, the vector area and the size of every contact.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/labels.hpp"

namespace graintwin::contacts {

/// Marks a value that could not be measured (e.g. the confidence of a contact without grey levels).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Exact sums over the contact voxels of one pair, in voxel index units (z, y, x).
struct PairSums {
  std::uint32_t low = 0, high = 0;                   ///< labels, low < high
  std::array<std::uint64_t, 2> voxels{};             ///< contact voxels of low, of high
  std::array<std::array<std::int64_t, 3>, 2> sum{};  ///< per side: sum of the contact voxels' (z, y, x)
  /// Neighbouring (26) voxel pairs (p of one grain, q of the other), each counted once, with the
  /// sums of p + q (twice their midpoint) and of its products zz, yy, xx, zy, zx, yx.
  std::uint64_t pairs = 0;
  std::array<std::int64_t, 3> pair_sum{};
  std::array<std::int64_t, 6> pair_moment{};
  /// Faces shared by a voxel of low and a voxel of high, signed +1 when low is on the lower-index
  /// side, per axis (z, y, x): the vector area of the interface in face units, pointing low -> high.
  std::array<std::int64_t, 3> faces{};
};

/// Sums for every pair of touching labels, sorted by (low, high).
///
/// labels: (nz, ny, nx), 0 = background. One raster pass, O(N): a vectorised test marks the voxels
/// that have a neighbour of another non-zero label, and only those are visited in detail (their
/// distinct neighbour labels, hashed pair keys). Parallel over z slabs with per-thread tables
/// merged by exact integer addition, so the result does not depend on the thread count.
/// `progress` (optional) receives the fraction of slabs done, from one thread.
std::vector<PairSums> contact_sums(const Volume<std::uint32_t>& labels,
                                   const std::function<void(double)>& progress = {});

/// One contact in physical units (positions, vectors and normals (x, y, z) in metres).
struct Contact {
  std::uint32_t low = 0, high = 0;           ///< labels, low < high
  std::uint64_t voxels_low = 0, voxels_high = 0;  ///< contact voxels of each grain
  Vec3 centroid{};      ///< m: mean position of the contact voxels of both grains
  Vec3 normal{};        ///< unit, PCA of the contact voxel pairs, oriented low -> high
  Vec3 vector_area{};   ///< m^2: sum of the oriented faces between the two grains (low -> high)
  double area = 0.0;    ///< m^2: |vector_area|; 0 when the grains meet only at edges or corners
  Vec3 branch{};        ///< m: centroid(high) - centroid(low)
};

struct DetectParams {
  /// A contact needs at least this many contact voxels on each side (2 = "more than 1 contact
  /// voxel" of the published method: a single voxel of one grain touching the other is not a contact).
  std::uint64_t min_voxels = 2;
};

/// Contacts from the pair sums. `grains` is the grain table (label and centroid used), sorted by
/// label; every label of a pair must have a row (DataError naming the label otherwise). Geometry
/// (voxel size, origin) comes from `like`.
///
/// Normal (PCA, docs/methods.md): eigenvector of the smallest eigenvalue of the covariance of the
/// midpoints of the neighbouring contact-voxel pairs (physical units), signed so that
/// n . (c_high - c_low) > 0 with the grain centroids; when that product is zero, the side means of
/// the contact voxels decide. The midpoints lie on the interface; the contact voxels themselves form
/// a slab two voxels thick, as thick as a small contact is wide, and their PCA errs 2.5 times more
/// (33 against 13 degrees at 8 voxels per diameter, docs/labels2contacts.md).
std::vector<Contact> contacts_from_sums(const std::vector<PairSums>& sums, const Volume<std::uint32_t>& like,
                                        const std::vector<segment::GrainRecord>& grains,
                                        const DetectParams& params = {});

/// contact_sums + contacts_from_sums.
std::vector<Contact> find_contacts(const Volume<std::uint32_t>& labels, const std::vector<segment::GrainRecord>& grains,
                                   const DetectParams& params = {}, const std::function<void(double)>& progress = {});

}  // namespace graintwin::contacts
