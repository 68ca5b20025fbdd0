// volconvert: bring CT images into GrainTwin (kind=volume .h5) or take them out as a TIFF stack.
//   volconvert scan.mhd scan.h5
//   volconvert 'slices/img_*.tif' scan.h5 --voxel-size 27.5um --crop 10:-10,:,:
//   volconvert scan.h5 scan.tif
#include <filesystem>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/tiff.hpp"
#include "graintwin/io/volume_convert.hpp"
#include "graintwin/io/volume_io.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

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
    io::ConvertOptions options;
    options.crop = crop_text;
    options.downsample = downsample;
    if (!voxel_text.empty()) options.voxel_size_m = parse_length_m(voxel_text, "--voxel-size");
    if (!cast_text.empty()) {
      options.cast = parse_dtype(cast_text);
      if (*options.cast == DType::uint32) throw UsageError("--cast uint32 is reserved for labels; use uint8, uint16 or float32");
    }
    const io::InputFormat format = io::detect_input_format(input.string(), !dims_text.empty());
    const io::RawLayout raw =
        format == io::InputFormat::raw ? io::raw_layout(dims_text, dtype_text, endian == "big", header_bytes) : io::RawLayout{};
    io::AtomicOutput out(output, ctx.force());
    if (format == io::InputFormat::h5)
      ctx.add_input_history(io::open_kind(input, schema::kind::volume, "volconvert converts kind=volume files"));

    const AnyVolume vol = io::convert_volume(io::read_input_volume(input, format, raw), options, input.string());
    if (out_tiff) io::write_tiff(out.temp_path(), vol);
    else io::write_volume_file(out.temp_path(), vol, ctx.history());
    throw_if_interrupted();
    io::commit_outputs({&out});
  });
}
