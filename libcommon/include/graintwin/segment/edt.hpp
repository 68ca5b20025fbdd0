#pragma once
// Exact Euclidean distance transform of a solid mask in physical units (anisotropic voxels), the
// relief that the markers and the watershed of ct2labels work on.
#include <cstdint>

#include "graintwin/core/volume.hpp"

namespace graintwin::segment {

/// Squared distance (in the units of `spacing`, squared) from each solid voxel (mask != 0) to the
/// centre of the nearest background voxel (mask == 0); 0 on background voxels.
///
/// mask: (nz, ny, nx); spacing: (dz, dy, dx) > 0. Separable and exact: a linear scan along x, then
/// the lower envelope of parabolas (Felzenszwalb & Huttenlocher 2012) along y and along z, O(N),
/// parallel over image lines, identical results for any thread count.
///
/// border_is_background = false (the default): the outside of the volume is neutral, so a grain cut
/// by the field of view keeps its distances to the real pore space only; a solid region with no
/// background voxel at all gets +infinity. true: the volume is taken as padded by one layer of
/// background, so distances never exceed the distance to the volume's faces plus one voxel.
Volume<float> squared_distance_transform(const Volume<std::uint8_t>& mask, const Vec3& spacing,
                                         bool border_is_background = false);

/// Distance in metres (sqrt of the above with the mask's voxel_size as spacing); the result has the
/// mask's shape, voxel size and origin. Every solid voxel gets at least the smallest voxel size.
Volume<float> distance_transform(const Volume<std::uint8_t>& mask, bool border_is_background = false);

}  // namespace graintwin::segment
