#pragma once
// Image filters shared by stages (ctsynth's point-spread blur, ct2labels' denoising).
#include "graintwin/core/volume.hpp"

namespace graintwin {

/// Separable Gaussian blur with sigma in voxels (kernel radius ceil(3 sigma), edges clamped), in
/// place; parallel over image lines. sigma <= 0 leaves the volume unchanged; a sigma that is not
/// finite is a UsageError.
void gaussian_blur(Volume<float>& v, double sigma_vox);

}  // namespace graintwin
