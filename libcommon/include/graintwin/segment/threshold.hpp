#pragma once
// Global thresholding of a grey CT volume into a solid mask (Otsu by default), and the optional
// clean-up of that mask: filling cavities enclosed by solid, and binary opening with a ball.
#include <cstdint>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/sample_region.hpp"

namespace graintwin::segment {

/// Otsu's threshold on a histogram: the bin edge e (a position in bin units, 1..B-1) that splits the
/// bins into [0, e) and [e, B) with the largest between-class variance. When several consecutive
/// splits tie (empty bins between the classes), e is the middle of the tied range, so a two-level
/// image is cut half-way between its levels. Throws DataError if fewer than two bins are non-empty.
double otsu_bin_edge(const std::vector<std::uint64_t>& histogram);

/// Otsu threshold t of a grey volume in its own units: solid is value > t (as in binarise).
/// uint8 / uint16: exact integer histogram (one bin per value). float: 4096 bins between the
/// minimum and the maximum. Throws DataError for an empty or constant volume ("Otsu is undefined
/// for a constant image; give --threshold") and for a float volume holding NaN or infinite values
/// (the message gives their number). Histograms are filled in parallel; the result does not depend
/// on the thread count.
template <class T>
double otsu_threshold(const Volume<T>& grey);

/// The same over the voxels whose centres lie inside `region` only (float: 4096 bins between the
/// minimum and the maximum inside). In a triaxial scan the region is the sample cylinder: inside it
/// the histogram holds only pores and grains, while over the whole volume the air around the sample
/// and a membrane of intermediate grey pull the threshold down (below the membrane's grey when the
/// grains take few voxels). Throws DataError if fewer than two grey levels lie inside.
template <class T>
double otsu_threshold(const Volume<T>& grey, const Cylinder& region);

/// Solid mask: 1 where value > threshold, else 0 (NaN gives 0); same geometry as `grey`.
template <class T>
Volume<std::uint8_t> binarise(const Volume<T>& grey, double threshold);

/// Fills cavities: background voxels (mask == 0) that are not 6-connected to a background voxel on
/// the volume's faces become solid (1). Breadth-first flood from the faces, O(N), memory of the
/// order of the flood front.
void fill_holes(Volume<std::uint8_t>& mask);

/// Binary opening (erosion then dilation) with the ball of radius `radius_vox` measured in voxel
/// steps (|(dz, dy, dx)| <= r, independent of the voxel size): removes solid features thinner
/// than the ball, such as noise specks and thin bridges. Exact, through two squared distance
/// transforms in voxel units; the outside of the volume is neutral (grains cut by the edge are
/// not eroded from it). Needs a temporary float volume. radius_vox <= 0 leaves the mask as is.
void binary_open(Volume<std::uint8_t>& mask, double radius_vox);

}  // namespace graintwin::segment
