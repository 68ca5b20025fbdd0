#pragma once
// Clean-up and measurement of a grain label image: sequential relabelling, small fragments merged
// into their neighbour or removed, grains cut by the field of view removed, and the grain table.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/connectivity.hpp"

namespace graintwin::segment {

/// Renumbers the non-zero labels 1..K in raster order (z, y, x) of each label's first voxel, in
/// place; returns K. Any uint32 labels are accepted.
std::uint32_t relabel_sequential(Volume<std::uint32_t>& labels);

/// What to do with a fragment smaller than the minimum voxel count.
enum class FragmentPolicy {
  merge,   ///< join the neighbouring label with which it shares the largest boundary (removed if it has none)
  remove,  ///< set to background
};

struct FragmentReport {
  std::size_t merged = 0;   ///< fragments joined to a neighbour
  std::size_t removed = 0;  ///< fragments set to background
};

/// Deals with every label of fewer than `min_voxels` voxels, in place. With `merge`, fragments are
/// taken from the smallest up (ties: lower label); each joins the neighbour label with the largest
/// boundary, counted as neighbouring voxel pairs under connectivity c (ties: lower label), and a
/// merged fragment that is still too small is reconsidered with its new size. Labels are not
/// renumbered (call relabel_sequential). Labels must not exceed the number of voxels. The boundary
/// count runs in parallel; the result does not depend on the thread count.
FragmentReport remove_small_fragments(Volume<std::uint32_t>& labels, std::size_t min_voxels,
                                      FragmentPolicy policy = FragmentPolicy::merge,
                                      Connectivity c = Connectivity::corners);

/// Sets to background every label with a voxel on a face of the volume; returns how many labels
/// were removed. Not renumbered.
std::size_t remove_edge_grains(Volume<std::uint32_t>& labels);

/// One row of the grain table.
struct GrainRecord {
  std::uint32_t label = 0;
  std::uint64_t voxels = 0;
  double volume_m3 = 0.0;                ///< voxels x dz dy dx
  Vec3 centroid_xyz{0.0, 0.0, 0.0};      ///< metres, (x, y, z): origin + mean index x voxel size
  std::array<std::size_t, 6> bbox{};     ///< (z0, y0, x0, z1, y1, x1), half-open index ranges
  bool touches_edge = false;             ///< some voxel lies on a face of the volume
};

/// The grain table, one record per label present, by increasing label. Exact integer sums per
/// thread, so the table is identical for any thread count. Labels must not exceed the number of
/// voxels (true after relabel_sequential).
std::vector<GrainRecord> grain_table(const Volume<std::uint32_t>& labels);

/// How `table` differs from grain_table(labels), as a clause for a message ("3 grains of the label
/// image have no row in the grain table (labels 8 to 10)"), or "" when every label of the image has
/// exactly its row: same voxel count, bounding box and edge flag, centroid within a millionth of a
/// voxel, volume within a relative 1e-9. Any labels are accepted (also labels beyond the voxel count).
std::string grain_table_mismatch(const Volume<std::uint32_t>& labels, const std::vector<GrainRecord>& table);

}  // namespace graintwin::segment
