#pragma once
// TIFF volumes through libtiff: multi-page stacks (classic and BigTIFF) and single 2-D slices.
// One grey sample per pixel; uint8, uint16 or float32. Pages are z slices, z = 0 first.
#include <filesystem>

#include "graintwin/core/volume.hpp"

namespace graintwin::io {

/// Reads every page of a (Big)TIFF as one z slice. Throws DataError naming the file when a page is
/// colour, tiled with an unsupported layout, of another size or of another sample type.
AnyVolume read_tiff(const std::filesystem::path& path);
/// Writes a multi-page TIFF, one page per z slice; BigTIFF when the data exceed 3.5 GiB. The voxel
/// size (x, y) is recorded as resolution in centimetres so ImageJ/Fiji show it.
void write_tiff(const std::filesystem::path& path, const AnyVolume& v);

}  // namespace graintwin::io
