#pragma once
// Raw volumes: MetaImage (.mhd header + raw file, or .mha with the data inline) and headerless raw
// files described on the command line.
#include <cstddef>
#include <filesystem>
#include <optional>

#include "graintwin/core/volume.hpp"

namespace graintwin::io {

/// Describes a headerless raw file: C order, z slowest.
struct RawLayout {
  Shape3 shape{0, 0, 0};          ///< (nz, ny, nx)
  DType dtype = DType::uint8;
  bool big_endian = false;
  std::size_t header_bytes = 0;   ///< bytes skipped at the start
  Vec3 voxel_size{1.0, 1.0, 1.0}; ///< metres (dz, dy, dx)
};

/// Reads a raw file; its size must be exactly header_bytes + product(shape) * bytes(dtype).
AnyVolume read_raw(const std::filesystem::path& path, const RawLayout& layout);
/// Reads a MetaImage .mhd/.mha (uncompressed; MET_UCHAR, MET_USHORT, MET_UINT, MET_FLOAT;
/// ElementSpacing taken as millimetres, the ITK convention).
AnyVolume read_metaimage(const std::filesystem::path& path);

}  // namespace graintwin::io
