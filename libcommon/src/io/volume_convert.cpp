#include "graintwin/io/volume_convert.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/tiff.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::io {

namespace fs = std::filesystem;

InputFormat detect_input_format(const std::string& in, bool raw_dims_given) {
  const std::string ext = lower(fs::path(in).extension().string());
  std::error_code ec;
  if (fs::is_directory(in, ec) || in.find_first_of("*?[") != std::string::npos) return InputFormat::slices;
  if (!fs::exists(in, ec)) throw UsageError("input " + in + " does not exist; check the path");
  if (raw_dims_given) return InputFormat::raw;
  if (ext == ".h5" || ext == ".hdf5") return InputFormat::h5;
  if (ext == ".tif" || ext == ".tiff") return InputFormat::tiff;
  if (ext == ".mhd" || ext == ".mha") return InputFormat::metaimage;
  if (ext == ".png") return InputFormat::slices;
  if (ext == ".raw" || ext == ".bin" || ext == ".vol")
    throw UsageError("input " + in + " is a headerless raw file; give its size with --dims Z,Y,X and --dtype");
  throw UsageError("input " + in + " has unknown format '" + ext +
                   "'; give .h5, .tif/.tiff, .mhd/.mha, a slice folder or glob, or raw with --dims");
}

Shape3 parse_dims(const std::string& text) {
  const auto parts = split(text, ',');
  if (parts.size() != 3) throw UsageError("--dims '" + text + "' must be three sizes Z,Y,X (z slowest)");
  Shape3 s{};
  for (int i = 0; i < 3; ++i) {
    const std::string part = trim(parts[i]);
    try {
      std::size_t used = 0;
      const long long v = std::stoll(part, &used);
      if (v <= 0 || used != part.size()) throw 0;  // "100abc" and "1e3" are not sizes
      s[i] = static_cast<std::size_t>(v);
    } catch (...) {
      throw UsageError("--dims '" + text + "': '" + parts[i] + "' is not a positive integer");
    }
  }
  return s;
}

RawLayout raw_layout(const std::string& dims, const std::string& dtype, bool big_endian, std::size_t header_bytes) {
  RawLayout raw;
  raw.shape = parse_dims(dims);
  raw.dtype = parse_dtype(dtype);
  // A product that wraps round in 64 bits would pass the file-size check and crash later.
  volume_bytes(raw.shape, dtype_bytes(raw.dtype), "--dims " + dims + " with --dtype " + dtype_name(raw.dtype));
  raw.big_endian = big_endian;
  raw.header_bytes = header_bytes;
  raw.voxel_size = {0.0, 0.0, 0.0};
  return raw;
}

AnyVolume read_input_volume(const fs::path& input, InputFormat format, const RawLayout& raw) {
  AnyVolume vol;
  switch (format) {
    case InputFormat::h5: {
      const H5File f = open_kind(input, schema::kind::volume, "volconvert converts kind=volume files");
      const ImageHeader h = read_image_header(f, schema::path::volume);
      check_memory(static_cast<double>(volume_bytes(h.shape, dtype_bytes(h.dtype), input.string())), "volconvert",
                   fmt::format("the {} x {} x {} {} voxels of {}", h.shape[0], h.shape[1], h.shape[2], dtype_name(h.dtype),
                               input.string()),
                   "convert it on a machine with more memory");
      vol = read_image(f, schema::path::volume);
      break;
    }
    case InputFormat::tiff: vol = read_tiff(input); break;
    case InputFormat::slices: {
      const auto files = list_slices(input.string());
      spdlog::info("{} slices, {} ... {}", files.size(), files.front().filename().string(), files.back().filename().string());
      vol = read_slices(files);
      break;
    }
    case InputFormat::metaimage: vol = read_metaimage(input); break;
    case InputFormat::raw: vol = read_raw(input, raw); break;
  }
  throw_if_interrupted();
  return vol;
}

AnyVolume convert_volume(AnyVolume vol, const ConvertOptions& options, const std::string& input_name) {
  const Shape3 s = shape_of_any(vol);
  if (s[0] * s[1] * s[2] == 0) throw DataError("input " + input_name + " holds an empty volume");
  std::visit([&](auto& v) {
    if (options.voxel_size_m) v.set_voxel_size({*options.voxel_size_m, *options.voxel_size_m, *options.voxel_size_m});
    for (double x : v.voxel_size())
      if (!(x > 0.0))
        throw UsageError("input " + input_name + " does not state its voxel size; give it with --voxel-size (e.g. 27.5um)");
  }, vol);

  if (!options.crop.empty()) vol = crop(vol, parse_crop(options.crop, s));
  if (options.downsample > 1) vol = downsample_mean(vol, options.downsample);
  if (options.cast) {
    std::size_t clamped = 0;
    vol = cast(vol, *options.cast, &clamped);
    if (clamped) spdlog::warn("--cast {}: {} values were outside the range and clamped", dtype_name(*options.cast), clamped);
  }
  const ValueRange r = value_range(vol);
  if (r.non_finite) spdlog::warn("{} voxels are NaN or infinite", r.non_finite);
  const Shape3 so = shape_of_any(vol);
  std::visit([&](const auto& v) {
    spdlog::info("{} x {} x {} (z,y,x) {}, voxel {:.4g} um, values {} .. {}", so[0], so[1], so[2], dtype_name(dtype_of_any(vol)),
                 v.voxel_size()[2] * 1e6, r.min, r.max);
  }, vol);
  return vol;
}

}  // namespace graintwin::io
