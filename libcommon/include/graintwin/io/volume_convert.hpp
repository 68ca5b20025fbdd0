#pragma once
// volconvert's stage: a CT image in any format GrainTwin reads (a kind=volume file, a multi-page
// TIFF, a folder or glob of 2-D TIFF/PNG slices, MetaImage, headerless raw) read into memory, then
// given its voxel size, cropped, block-mean downsampled and cast as asked.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

#include "graintwin/core/volume.hpp"
#include "graintwin/io/metaimage.hpp"

namespace graintwin::io {

enum class InputFormat { h5, tiff, slices, metaimage, raw };

/// The format of `input`: slices for a folder or a glob, raw whenever raw dimensions are given
/// (`raw_dims_given`), else by extension (.h5/.hdf5, .tif/.tiff, .mhd/.mha, .png: one slice).
/// UsageError when the input does not exist, is a headerless raw file (.raw, .bin, .vol) without
/// dimensions, or has another extension.
InputFormat detect_input_format(const std::string& input, bool raw_dims_given);

/// --dims: "Z,Y,X", three positive whole numbers, z slowest; UsageError otherwise.
Shape3 parse_dims(const std::string& text);

/// The layout of a headerless raw file from --dims, --dtype, its byte order and the bytes before
/// the data; its voxel size is unknown (0). UsageError for bad dimensions or type, or dimensions
/// whose byte count exceeds 64 bits.
RawLayout raw_layout(const std::string& dims, const std::string& dtype, bool big_endian, std::size_t header_bytes);

/// Reads `input` of `format` (with `raw` for raw input). A kind=volume file is read only when its
/// voxels fit in the memory this process may use (UsageError with the numbers otherwise); the
/// slices' count, first and last file are logged. InterruptedError when interrupted meanwhile.
AnyVolume read_input_volume(const std::filesystem::path& input, InputFormat format, const RawLayout& raw = {});

/// What volconvert does to the volume it read, in this order.
struct ConvertOptions {
  std::optional<double> voxel_size_m;  ///< cubic voxels of this size (m) in place of the input's
  std::string crop;                    ///< z0:z1,y0:y1,x0:x1 (parse_crop); empty: the whole volume
  std::size_t downsample = 1;          ///< block mean over n x n x n voxels; 1: none
  std::optional<DType> cast;           ///< rounded and clamped to this type
};

/// `volume` (read from `input_name`) converted as `options` ask; the result's shape, type, voxel
/// size and value range are logged, with warnings for clamped values and NaN or infinite voxels.
/// DataError for an empty volume; UsageError when the voxel size is neither stated nor given, or
/// for a crop that selects nothing.
AnyVolume convert_volume(AnyVolume volume, const ConvertOptions& options, const std::string& input_name);

}  // namespace graintwin::io
