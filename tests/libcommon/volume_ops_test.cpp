// Volume indexing, crop, downsample, cast, value range, and the text helpers they rely on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "support/fixtures.hpp"

using namespace graintwin;

TEST(Volume, IndexIsZYXWithXFastest) {
  Volume<std::uint16_t> v({2, 3, 4});
  v(1, 2, 3) = 7;
  EXPECT_EQ(v.values()[((1 * 3) + 2) * 4 + 3], 7);
  EXPECT_EQ(v.index(0, 0, 1), 1u);
  EXPECT_EQ(v.index(0, 1, 0), 4u);
  EXPECT_EQ(v.index(1, 0, 0), 12u);
}

TEST(Volume, PositionIsXYZOfVoxelCentre) {
  Volume<float> v({2, 2, 2}, {3.0, 2.0, 1.0}, {10.0, 20.0, 30.0});
  const Vec3 p = v.position_xyz(1, 1, 1);
  EXPECT_DOUBLE_EQ(p[0], 31.0);  // x
  EXPECT_DOUBLE_EQ(p[1], 22.0);  // y
  EXPECT_DOUBLE_EQ(p[2], 13.0);  // z
}

TEST(Crop, ParsesPythonStyleRanges) {
  const CropBox b = parse_crop("1:3,:,-2:", {5, 6, 7});
  EXPECT_EQ(b.begin, (Shape3{1, 0, 5}));
  EXPECT_EQ(b.end, (Shape3{3, 6, 7}));
  EXPECT_THROW(parse_crop("1:3,:", {5, 6, 7}), UsageError);
  EXPECT_THROW(parse_crop("3:3,:,:", {5, 6, 7}), UsageError);
  EXPECT_THROW(parse_crop("a:3,:,:", {5, 6, 7}), UsageError);
}

TEST(Crop, CopiesTheBoxAndMovesTheOrigin) {
  auto v = test::ramp_volume<std::uint16_t>({5, 6, 7}, {1.0, 1.0, 1.0});
  const auto c = crop(v, parse_crop("1:3,2:5,4:", v.shape()));
  ASSERT_EQ(c.shape(), (Shape3{2, 3, 3}));
  for (std::size_t z = 0; z < 2; ++z)
    for (std::size_t y = 0; y < 3; ++y)
      for (std::size_t x = 0; x < 3; ++x) EXPECT_EQ(c(z, y, x), v(z + 1, y + 2, x + 4));
  EXPECT_DOUBLE_EQ(c.origin()[0], 1.0);
  EXPECT_DOUBLE_EQ(c.origin()[2], 4.0);
}

TEST(Downsample, BlockMeanRoundsIntegersAndScalesGeometry) {
  Volume<std::uint8_t> v({4, 4, 4}, {1.0, 1.0, 1.0});
  for (std::size_t i = 0; i < v.size(); ++i) v.values()[i] = static_cast<std::uint8_t>(i % 2 ? 3 : 0);
  const auto d = downsample_mean(v, 2);
  ASSERT_EQ(d.shape(), (Shape3{2, 2, 2}));
  EXPECT_EQ(d(0, 0, 0), 2);  // mean 1.5 rounds to 2
  EXPECT_DOUBLE_EQ(d.voxel_size()[0], 2.0);
  EXPECT_DOUBLE_EQ(d.origin()[0], 0.5);  // centre of the first 2-voxel block
  EXPECT_THROW(downsample_mean(v, 5), UsageError);
}

TEST(Downsample, DropsPartialBlocks) {
  Volume<float> v({5, 5, 5}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}, 2.0f);
  const auto d = downsample_mean(v, 2);
  EXPECT_EQ(d.shape(), (Shape3{2, 2, 2}));
  EXPECT_FLOAT_EQ(d(1, 1, 1), 2.0f);
}

TEST(Cast, ClampsAndCountsOutOfRangeValues) {
  Volume<float> v({1, 1, 4});
  v.values() = {-3.0f, 12.6f, 300.0f, std::numeric_limits<float>::quiet_NaN()};
  std::size_t clamped = 0;
  const AnyVolume out = cast(AnyVolume{v}, DType::uint8, &clamped);
  const auto& u = std::get<Volume<std::uint8_t>>(out);
  EXPECT_EQ(u.values(), (std::vector<std::uint8_t>{0, 13, 255, 0}));
  EXPECT_EQ(clamped, 3u);
}

TEST(ValueRange, SkipsNonFiniteValues) {
  std::vector<float> x{1.0f, std::numeric_limits<float>::infinity(), -2.0f, std::nanf("")};
  const ValueRange r = value_range(x.data(), x.size());
  EXPECT_EQ(r.non_finite, 2u);
  EXPECT_DOUBLE_EQ(r.min, -2.0);
  EXPECT_DOUBLE_EQ(r.max, 1.0);
  EXPECT_DOUBLE_EQ(r.mean, -0.5);
}

TEST(DType, ParsesNamesAndRejectsOthers) {
  EXPECT_EQ(parse_dtype("u16"), DType::uint16);
  EXPECT_EQ(parse_dtype("Float32"), DType::float32);
  EXPECT_THROW(parse_dtype("int16"), UsageError);
}

TEST(Strings, NaturalOrder) {
  EXPECT_TRUE(natural_less("slice2.tif", "slice10.tif"));
  EXPECT_FALSE(natural_less("slice10.tif", "slice2.tif"));
  EXPECT_TRUE(natural_less("a_9", "b_1"));
  EXPECT_TRUE(natural_less("img001", "img2"));
}

TEST(Strings, LengthsWithUnits) {
  EXPECT_DOUBLE_EQ(parse_length_m("27.5um", "x"), 27.5e-6);
  EXPECT_DOUBLE_EQ(parse_length_m("0.0607 mm", "x"), 0.0607e-3);
  EXPECT_DOUBLE_EQ(parse_length_m("2e-5", "x"), 2e-5);
  EXPECT_THROW(parse_length_m("-1um", "x"), UsageError);
  EXPECT_THROW(parse_length_m("3 furlongs", "x"), UsageError);
  EXPECT_THROW(parse_length_m("nan", "x"), UsageError);
  // The options and ImageJ's TIFF headers read one unit table.
  EXPECT_DOUBLE_EQ(parse_length_m("3 micron", "x"), 3e-6);
  EXPECT_DOUBLE_EQ(parse_length_m("2cm", "x"), 2e-2);
  EXPECT_EQ(length_unit_m("\\u00b5m"), 1e-6);
  EXPECT_EQ(length_unit_m("nm"), 1e-9);
  EXPECT_FALSE(length_unit_m("furlongs"));
}

TEST(Strings, ShellQuoting) {
  EXPECT_EQ(shell_quote("scan.h5"), "scan.h5");
  EXPECT_EQ(shell_quote("a b"), "'a b'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
}
