// volconvert: bring CT images into GrainTwin (kind=volume .h5) or take them out as a TIFF stack.
//   volconvert scan.mhd scan.h5
//   volconvert 'slices/img_*.tif' scan.h5 --voxel-size 27.5um --crop 10:-10,:,:
//   volconvert scan.h5 scan.tif
#include <filesystem>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/metaimage.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/tiff.hpp"
#include "graintwin/io/volume_io.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

namespace {

enum class InputFormat { h5, tiff, slices, metaimage, raw };

InputFormat detect_input(const std::string& in, bool have_dims) {
  const std::string ext = lower(fs::path(in).extension().string());
  std::error_code ec;
  if (fs::is_directory(in, ec) || in.find_first_of("*?[") != std::string::npos) return InputFormat::slices;
  if (!fs::exists(in, ec)) throw UsageError("input " + in + " does not exist; check the path");
  if (have_dims) return InputFormat::raw;
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

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("volconvert",
                 "Convert CT volumes into GrainTwin's kind=volume HDF5 (or out to a multi-page TIFF), with "
                 "optional crop, block-mean downsampling and type cast. Reads multi-page (Big)TIFF, folders "
                 "or globs of 2-D TIFF/PNG slices (natural order), MetaImage .mhd/.mha, headerless raw "
                 "(--dims, --dtype) and .h5. Data are copied bit-exact unless --downsample or --cast asks "
                 "otherwise.");
  fs::path input, output;
  std::string crop_text, dims_text, dtype_text = "uint8", cast_text, voxel_text, endian = "little";
  std::size_t downsample = 1, header_bytes = 0;
  auto& app = tool.cli();
  tool.add_input("input", input,
                 "Input: .h5 (kind=volume), .tif/.tiff stack, slice folder or quoted glob, .mhd/.mha, or raw "
                 "file with --dims",
                 false);
  tool.add_output("output", output, "Output: .h5 (kind=volume) or .tif/.tiff (multi-page stack)");
  app.add_option("--crop", crop_text, "Keep z0:z1,y0:y1,x0:x1 (half-open voxel ranges; empty = edge, negative = from end)");
  app.add_option("--downsample", downsample, "Block mean over N x N x N voxels (voxel size grows by N)")
      ->check(cli::whole_number_in(1, 1000))
      ->capture_default_str();
  app.add_option("--cast", cast_text, "Convert to uint8, uint16 or float32 (rounds, clamps and reports clamping)");
  app.add_option("--voxel-size", voxel_text,
                 "Voxel size where the input lacks it or to override it, e.g. 27.5um, 0.0607mm, 2.75e-5 (m)")
      ->check(cli::length_in(1e-9, 0.1));
  app.add_option("--dims", dims_text, "Raw input: sizes Z,Y,X (z slowest, x fastest)");
  app.add_option("--dtype", dtype_text, "Raw input: uint8, uint16, uint32 or float32")->capture_default_str();
  app.add_option("--endian", endian, "Raw input byte order")->check(CLI::IsMember({"little", "big"}))->capture_default_str();
  app.add_option("--header-bytes", header_bytes, "Raw input: bytes to skip before the data")
      ->check(cli::whole_number_in(0, 1LL << 50, "bytes"))->capture_default_str();
  tool.set_examples({"volconvert soil.mhd soil.h5",
                     "volconvert 'scan/slice_*.tif' scan.h5 --voxel-size 27.5um --crop 100:-100,:,:",
                     "volconvert scan.raw scan.h5 --dims 100,256,256 --dtype uint16 --voxel-size 0.0607mm",
                     "volconvert scan.h5 scan_half.h5 --downsample 2",
                     "volconvert scan.h5 scan.tif"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Validate every option before reading anything.
    const std::string out_ext = lower(output.extension().string());
    const bool out_tiff = out_ext == ".tif" || out_ext == ".tiff";
    if (!out_tiff && out_ext != ".h5" && out_ext != ".hdf5")
      throw UsageError("output " + output.string() + " must end in .h5 or .tif/.tiff");
    std::optional<double> voxel_m;
    if (!voxel_text.empty()) voxel_m = parse_length_m(voxel_text, "--voxel-size");
    std::optional<DType> cast_to;
    if (!cast_text.empty()) {
      cast_to = parse_dtype(cast_text);
      if (*cast_to == DType::uint32) throw UsageError("--cast uint32 is reserved for labels; use uint8, uint16 or float32");
    }
    const bool have_dims = !dims_text.empty();
    const InputFormat fmt = detect_input(input.string(), have_dims);
    io::RawLayout raw;
    if (fmt == InputFormat::raw) {
      raw.shape = parse_dims(dims_text);
      raw.dtype = parse_dtype(dtype_text);
      // A product that wraps round in 64 bits would pass the file-size check and crash later.
      volume_bytes(raw.shape, dtype_bytes(raw.dtype), "--dims " + dims_text + " with --dtype " + dtype_name(raw.dtype));
      raw.big_endian = endian == "big";
      raw.header_bytes = header_bytes;
      raw.voxel_size = {0.0, 0.0, 0.0};
    }
    io::AtomicOutput out(output, ctx.force());

    AnyVolume vol;
    switch (fmt) {
      case InputFormat::h5: {
        const io::H5File f = io::open_kind(input, schema::kind::volume, "volconvert converts kind=volume files");
        ctx.add_input_history(f);
        const io::ImageHeader h = io::read_image_header(f, schema::path::volume);
        check_memory(static_cast<double>(volume_bytes(h.shape, dtype_bytes(h.dtype), input.string())), "volconvert",
                     fmt::format("the {} x {} x {} {} voxels of {}", h.shape[0], h.shape[1], h.shape[2], dtype_name(h.dtype),
                                 input.string()),
                     "convert it on a machine with more memory");
        vol = io::read_image(f, schema::path::volume);
        break;
      }
      case InputFormat::tiff: vol = io::read_tiff(input); break;
      case InputFormat::slices: {
        const auto files = io::list_slices(input.string());
        spdlog::info("{} slices, {} ... {}", files.size(), files.front().filename().string(),
                     files.back().filename().string());
        vol = io::read_slices(files);
        break;
      }
      case InputFormat::metaimage: vol = io::read_metaimage(input); break;
      case InputFormat::raw: vol = io::read_raw(input, raw); break;
    }
    throw_if_interrupted();

    const Shape3 s = shape_of_any(vol);
    if (s[0] * s[1] * s[2] == 0) throw DataError("input " + input.string() + " holds an empty volume");
    std::visit([&](auto& v) {
      if (voxel_m) v.set_voxel_size({*voxel_m, *voxel_m, *voxel_m});
      for (double x : v.voxel_size())
        if (!(x > 0.0))
          throw UsageError("input " + input.string() + " does not state its voxel size; give it with --voxel-size (e.g. 27.5um)");
    }, vol);

    if (!crop_text.empty()) vol = crop(vol, parse_crop(crop_text, s));
    if (downsample > 1) vol = downsample_mean(vol, downsample);
    if (cast_to) {
      std::size_t clamped = 0;
      vol = cast(vol, *cast_to, &clamped);
      if (clamped) spdlog::warn("--cast {}: {} values were outside the range and clamped", cast_text, clamped);
    }
    const ValueRange r = value_range(vol);
    if (r.non_finite) spdlog::warn("{} voxels are NaN or infinite", r.non_finite);
    const Shape3 so = shape_of_any(vol);
    std::visit([&](const auto& v) {
      spdlog::info("{} x {} x {} (z,y,x) {}, voxel {:.4g} um, values {} .. {}", so[0], so[1], so[2],
                   dtype_name(dtype_of_any(vol)), v.voxel_size()[2] * 1e6, r.min, r.max);
    }, vol);

    if (out_tiff) io::write_tiff(out.temp_path(), vol);
    else io::write_volume_file(out.temp_path(), vol, ctx.history());
    throw_if_interrupted();
    io::commit_outputs({&out});
  });
}
