#pragma once
// Marker-controlled watershed of the negated distance transform, restricted to the solid mask:
// splits touching grains along the necks between EDT peaks.
#include <cstdint>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/connectivity.hpp"

namespace graintwin::segment {

/// Floods -edt from the markers over the solid mask (the voxels with edt > 0) and returns the
/// labels (the markers volume, reused in place: pass it with std::move to avoid a copy).
///
/// edt: distances in metres (distance_transform); markers: same shape, 1..K (0 = none, K below
/// 2^31, else UsageError), e.g. from h_maxima_markers or peak_markers. Every mask voxel connected
/// to a marker gets the label of the basin that reaches it first; there are no watershed lines;
/// marker voxels outside the mask are dropped and mask components without a marker stay 0.
/// Priority flooding with a hierarchical queue of quantised levels (squared distance, 8 levels per
/// squared voxel: exact order for an isotropic EDT up to 181 voxels) and a FIFO per level, O(N),
/// sequential and deterministic. Memory: the labels plus the queue, which holds only the flood
/// front (uint32 entries below 2^32 voxels; about 0.75 byte per voxel on a 256^3 sphere packing).
Volume<std::uint32_t> watershed(const Volume<float>& edt, Volume<std::uint32_t> markers,
                                Connectivity c = Connectivity::corners);

}  // namespace graintwin::segment
