#pragma once
// Edge-preserving denoising of a grey CT volume before thresholding: the 3x3x3 median filter.
// (Gaussian smoothing is graintwin::gaussian_blur in core/filters.hpp.)
#include "graintwin/core/volume.hpp"

namespace graintwin::segment {

/// 3x3x3 median of every voxel, edges replicated (the volume is extended by its border values);
/// returns a new volume of the same shape and geometry. Removes salt-and-pepper noise and isolated
/// outliers while keeping grain edges in place. For T = uint8_t, uint16_t, float; a float volume
/// holding NaN is refused with a DataError (NaN has no rank). Parallel over z slices.
template <class T>
Volume<T> median3(const Volume<T>& grey);

}  // namespace graintwin::segment
