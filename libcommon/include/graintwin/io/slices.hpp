#pragma once
// 2-D slice series (TIFF or PNG files in a folder or matching a glob) read as one volume.
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"

namespace graintwin::io {

/// Files of a folder (every .tif/.tiff/.png in it) or of a glob pattern ("scan/img_*.tif"), in
/// natural order. Throws UsageError when nothing matches.
std::vector<std::filesystem::path> list_slices(const std::string& folder_or_glob);
/// Reads the slices as z = 0, 1, ...; all must share size and sample type.
AnyVolume read_slices(const std::vector<std::filesystem::path>& files);
/// Reads one 8- or 16-bit grey PNG as a 1 x ny x nx volume.
AnyVolume read_png(const std::filesystem::path& path);
/// Writes a 2-D uint8 or uint16 grey image (a 1 x ny x nx volume) as PNG.
void write_png(const std::filesystem::path& path, const AnyVolume& slice);
/// Writes an 8-bit RGB image, rows top to bottom, pixels (r, g, b) interleaved (3 * width * height bytes).
void write_png_rgb(const std::filesystem::path& path, std::size_t width, std::size_t height,
                   const std::vector<std::uint8_t>& rgb);

}  // namespace graintwin::io
