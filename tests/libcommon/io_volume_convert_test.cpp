// volconvert's stage (io/volume_convert): the input's format from its name, raw layouts from the
// options, reading every format, and the conversions in their order with the refusals.
#include <gtest/gtest.h>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/volume_convert.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/fixtures.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::io;

TEST(VolumeConvert, TheFormatFollowsTheNameAndRawDimensions) {
  test::TempDir dir;
  for (const char* name : {"a.h5", "b.HDF5", "c.tif", "d.tiff", "e.mhd", "f.mha", "g.png", "h.raw", "i.vol", "j.xyz"})
    std::ofstream(dir / name) << "x";
  EXPECT_EQ(detect_input_format((dir / "a.h5").string(), false), InputFormat::h5);
  EXPECT_EQ(detect_input_format((dir / "b.HDF5").string(), false), InputFormat::h5);
  EXPECT_EQ(detect_input_format((dir / "d.tiff").string(), false), InputFormat::tiff);
  EXPECT_EQ(detect_input_format((dir / "f.mha").string(), false), InputFormat::metaimage);
  EXPECT_EQ(detect_input_format((dir / "g.png").string(), false), InputFormat::slices);
  EXPECT_EQ(detect_input_format(dir.path().string(), false), InputFormat::slices);  // a folder
  EXPECT_EQ(detect_input_format((dir / "slice_*.tif").string(), false), InputFormat::slices);
  EXPECT_EQ(detect_input_format((dir / "c.tif").string(), true), InputFormat::raw);  // --dims wins
  EXPECT_EQ(detect_input_format((dir / "h.raw").string(), true), InputFormat::raw);
  EXPECT_THROW(detect_input_format((dir / "i.vol").string(), false), UsageError);  // raw without --dims
  EXPECT_THROW(detect_input_format((dir / "j.xyz").string(), false), UsageError);
  EXPECT_THROW(detect_input_format((dir / "none.h5").string(), false), UsageError);
}

TEST(VolumeConvert, RawLayoutsComeFromTheOptions) {
  const RawLayout r = raw_layout("4, 5,6", "u16", true, 12);
  EXPECT_EQ(r.shape, (Shape3{4, 5, 6}));
  EXPECT_EQ(r.dtype, DType::uint16);
  EXPECT_TRUE(r.big_endian);
  EXPECT_EQ(r.header_bytes, 12u);
  EXPECT_EQ(r.voxel_size[0], 0.0);  // unknown until --voxel-size
  EXPECT_THROW(raw_layout("4,5", "uint8", false, 0), UsageError);
  EXPECT_THROW(raw_layout("4,5,0", "uint8", false, 0), UsageError);
  EXPECT_THROW(raw_layout("4,5,1e3", "uint8", false, 0), UsageError);
  EXPECT_THROW(raw_layout("4,5,6", "int16", false, 0), UsageError);
  EXPECT_THROW(raw_layout("128,144115188075856997,1", "uint16", false, 0), UsageError);  // wraps round in 64 bits
}

TEST(VolumeConvert, EveryFormatReadsTheSameVoxels) {
  test::TempDir dir;
  const Volume<std::uint16_t> v = test::ramp_volume<std::uint16_t>({3, 4, 5});
  write_volume_file(dir / "v.h5", v, {"ramp"});
  const auto mhd = test::write_mhd(dir.path(), "m", v);
  EXPECT_TRUE(test::same_voxels(read_input_volume(dir / "v.h5", InputFormat::h5), v));
  EXPECT_TRUE(test::same_voxels(read_input_volume(mhd, InputFormat::metaimage), v));
  EXPECT_TRUE(test::same_voxels(read_input_volume(dir / "m.raw", InputFormat::raw, raw_layout("3,4,5", "uint16", false, 0)), v));
  // The kind=volume reader refuses other files.
  EXPECT_THROW(read_input_volume(mhd, InputFormat::h5), UsageError);
}

TEST(VolumeConvert, ConversionsRunInOrderAndRefuseWhatCannotBeWritten) {
  const Volume<std::uint16_t> v = test::ramp_volume<std::uint16_t>({4, 6, 8}, {1e-5, 1e-5, 1e-5});
  ConvertOptions o;
  o.voxel_size_m = 3e-5;
  o.crop = "0:4,1:5,:";
  o.downsample = 2;
  o.cast = DType::float32;
  const AnyVolume out = convert_volume(v, o, "ramp");
  ASSERT_TRUE(std::holds_alternative<Volume<float>>(out));
  const auto& f = std::get<Volume<float>>(out);
  EXPECT_EQ(f.shape(), (Shape3{2, 2, 4}));                 // cropped to 4 x 4 x 8, then halved
  EXPECT_DOUBLE_EQ(f.voxel_size()[0], 6e-5);               // the given size, then doubled
  const CropBox box = parse_crop(o.crop, v.shape());
  const AnyVolume expected = cast(downsample_mean(crop(AnyVolume(v), box), 2), DType::float32);
  EXPECT_TRUE(test::same_voxels(out, expected));

  Volume<std::uint16_t> no_size({2, 2, 2}, {0.0, 0.0, 0.0});
  EXPECT_THROW(convert_volume(no_size, {}, "raw"), UsageError);
  EXPECT_THROW(convert_volume(Volume<std::uint8_t>({0, 2, 2}, {1e-5, 1e-5, 1e-5}), {}, "empty"), DataError);
  ConvertOptions outside;
  outside.crop = "5:9,:,:";
  EXPECT_THROW(convert_volume(v, outside, "ramp"), UsageError);
}
