#pragma once
// Denoising of a grey CT volume before thresholding: a Gaussian of small sigma (the default of
// ct2labels) and the edge-preserving 3x3x3 median filter.
#include "graintwin/core/volume.hpp"

namespace graintwin::segment {

/// 3x3x3 median of every voxel, edges replicated (the volume is extended by its border values);
/// returns a new volume of the same shape and geometry. Removes salt-and-pepper noise and isolated
/// outliers while keeping grain edges in place. For T = uint8_t, uint16_t, float; a float volume
/// holding NaN is refused with a DataError (NaN has no rank). Parallel over z slices.
template <class T>
Volume<T> median3(const Volume<T>& grey);

/// Gaussian smoothing of sigma `sigma_vox` voxel steps along each axis (kernel truncated at
/// ceil(3 sigma), normalised; edges replicated, as core/filters.hpp gaussian_blur, to which it is
/// equal up to float rounding), stored back in T (integers rounded; the result stays within the
/// input range). Separable, a pass per axis on whole rows (vectorised), parallel over rows and
/// planes. Memory: a float volume for integer T (none for float: in place) plus a plane per thread.
/// sigma_vox <= 0 returns the volume unchanged.
template <class T>
Volume<T> gaussian_smooth(Volume<T> grey, double sigma_vox);

}  // namespace graintwin::segment
