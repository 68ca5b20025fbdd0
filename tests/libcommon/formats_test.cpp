// Foreign image formats: (Big)TIFF stacks, slice series (TIFF/PNG), MetaImage and raw.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/io/metaimage.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/tiff.hpp"
#include "support/errors.hpp"
#include "support/fixtures.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::io;
namespace fs = std::filesystem;

namespace {
// A TIFF written with libtiff directly, so our reader is tested on files it did not write.
void write_plain_tiff(const fs::path& p, int pages, int spp, bool big) {
  TIFF* t = TIFFOpen(p.c_str(), big ? "w8" : "w");
  ASSERT_NE(t, nullptr);
  for (int z = 0; z < pages; ++z) {
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 5u);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, 4u);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 16);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, spp);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, spp == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_LZW);
    std::vector<std::uint16_t> row(5 * spp);
    for (std::uint32_t y = 0; y < 4; ++y) {
      for (int x = 0; x < 5 * spp; ++x) row[x] = static_cast<std::uint16_t>(1000 * z + 10 * y + x);
      TIFFWriteScanline(t, row.data(), y, 0);
    }
    TIFFWriteDirectory(t);
  }
  TIFFClose(t);
}
}  // namespace

TEST(Tiff, ThreePageStackIsAVolumeNotAColourImage) {
  test::TempDir dir;
  write_plain_tiff(dir / "three.tif", 3, 1, false);
  const AnyVolume v = read_tiff(dir / "three.tif");
  ASSERT_EQ(shape_of_any(v), (Shape3{3, 4, 5}));
  const auto& u = std::get<Volume<std::uint16_t>>(v);
  EXPECT_EQ(u(2, 3, 4), 2034);
}

TEST(Tiff, ReadsBigTiff) {
  test::TempDir dir;
  write_plain_tiff(dir / "big.tif", 2, 1, true);
  const AnyVolume v = read_tiff(dir / "big.tif");
  const auto& u = std::get<Volume<std::uint16_t>>(v);
  EXPECT_EQ(u(1, 2, 3), 1023);
}

TEST(Tiff, RejectsColourPages) {
  test::TempDir dir;
  write_plain_tiff(dir / "rgb.tif", 1, 3, false);
  try {
    read_tiff(dir / "rgb.tif");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("colour"), std::string::npos);
  }
}

TEST(Tiff, RoundTripIsBitExactWithGeometry) {
  test::TempDir dir;
  for (const AnyVolume& v : {AnyVolume{test::ramp_volume<std::uint8_t>({4, 5, 6})},
                             AnyVolume{test::ramp_volume<std::uint16_t>({4, 5, 6})},
                             AnyVolume{test::ramp_volume<float>({4, 5, 6}, {3e-5, 2e-5, 1e-5})}}) {
    write_tiff(dir / "rt.tif", v);
    const AnyVolume back = read_tiff(dir / "rt.tif");
    EXPECT_TRUE(test::same_voxels(v, back));
    std::visit([&](const auto& b) {
      std::visit([&](const auto& a) { EXPECT_EQ(a.voxel_size(), b.voxel_size()); }, v);
    }, back);
  }
}

TEST(Tiff, TruncatedFileIsADataError) {
  test::TempDir dir;
  write_tiff(dir / "t.tif", test::ramp_volume<std::uint16_t>({3, 64, 64}));
  fs::resize_file(dir / "t.tif", fs::file_size(dir / "t.tif") / 2);
  EXPECT_THROW(read_tiff(dir / "t.tif"), DataError);
}

TEST(Slices, NaturalOrderFolderOfPngs) {
  test::TempDir dir;
  auto v = test::ramp_volume<std::uint16_t>({12, 3, 4});
  for (std::size_t z = 0; z < 12; ++z) {
    Volume<std::uint16_t> s({1, 3, 4});
    std::copy(&v(z, 0, 0), &v(z, 0, 0) + 12, s.data());
    write_png(dir / ("img" + std::to_string(z) + ".png"), s);  // img10 must follow img9
  }
  const auto files = list_slices(dir.path().string());
  ASSERT_EQ(files.size(), 12u);
  EXPECT_EQ(files[10].filename(), "img10.png");
  EXPECT_TRUE(test::same_voxels(read_slices(files), v));
  EXPECT_EQ(list_slices((dir.path() / "img1*.png").string()).size(), 3u);  // img1, img10, img11
}

TEST(Slices, EmptyFolderAndMismatchedSlicesAreRefused) {
  test::TempDir dir;
  EXPECT_THROW(list_slices(dir.path().string()), UsageError);
  write_png(dir / "a1.png", test::ramp_volume<std::uint8_t>({1, 3, 4}));
  write_png(dir / "a2.png", test::ramp_volume<std::uint8_t>({1, 4, 4}));
  EXPECT_THROW(read_slices(list_slices(dir.path().string())), DataError);
}

TEST(MetaImage, ReadsHeaderGeometryAndData) {
  test::TempDir dir;
  const auto v = test::ramp_volume<std::uint16_t>({3, 4, 5}, {6.07e-5, 6.07e-5, 6.07e-5});
  const fs::path mhd = test::write_mhd(dir.path(), "s", v);
  const AnyVolume back = read_metaimage(mhd);
  EXPECT_TRUE(test::same_voxels(v, back));
  EXPECT_NEAR(std::get<Volume<std::uint16_t>>(back).voxel_size()[0], 6.07e-5, 1e-12);
}

TEST(MetaImage, SizeMismatchNamesTheHeader) {
  test::TempDir dir;
  const fs::path mhd = test::write_mhd(dir.path(), "s", test::ramp_volume<std::uint8_t>({3, 4, 5}));
  fs::resize_file(dir / "s.raw", 59);  // truncated raw
  try {
    read_metaimage(mhd);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("DimSize"), std::string::npos);
  }
}

namespace {
std::string metaimage_error(const fs::path& dir, const std::string& header) {
  std::ofstream(dir / "h.mha", std::ios::binary) << header;
  return test::message_of([&] { read_metaimage(dir / "h.mha"); });
}
}  // namespace

TEST(MetaImage, HeaderNumbersAreCheckedAndNamed) {
  test::TempDir dir;
  const std::string head = "NDims = 3\nElementType = MET_UCHAR\n";
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 1 1 x\nElementDataFile = LOCAL\n").find("DimSize = 1 1 x is not a list of whole numbers"),
            std::string::npos);
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 2 2 -2\nElementDataFile = LOCAL\n").find("DimSize"), std::string::npos);
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 1 1 1\nElementSpacing = 1 nan 1\nElementDataFile = LOCAL\nA")
                .find("ElementSpacing = 1 nan 1 is not a list of finite numbers"),
            std::string::npos);
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 1 1 1\nElementSpacing = 1 0 1\nElementDataFile = LOCAL\nA").find("must be positive"),
            std::string::npos);
  // 2^32 x 2^32 x 1 bytes wraps to 0 in 64 bits: no longer taken for an empty volume.
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 4294967296 4294967296 1\nElementDataFile = LOCAL\n").find("more bytes than a 64-bit size counts"),
            std::string::npos);
  // A DimSize beyond the inline data is refused before anything is allocated.
  EXPECT_NE(metaimage_error(dir.path(), head + "DimSize = 100000 100000 100\nElementDataFile = LOCAL\nABCD")
                .find("holds 4 bytes of data after its header but DimSize x ElementType needs 1000000000000"),
            std::string::npos);
}

TEST(MetaImage, HeaderSizeMinusOneReadsTheLastBytes) {
  test::TempDir dir;
  std::ofstream(dir / "d.raw", std::ios::binary) << "junk" << std::string("\x01\x02\x03\x04", 4);
  std::ofstream(dir / "d.mhd") << "NDims = 3\nDimSize = 2 2 1\nElementType = MET_UCHAR\nHeaderSize = -1\nElementDataFile = d.raw\n";
  const auto v = std::get<Volume<std::uint8_t>>(read_metaimage(dir / "d.mhd"));
  EXPECT_EQ(v.values(), (std::vector<std::uint8_t>{1, 2, 3, 4}));
  std::ofstream(dir / "e.mhd") << "NDims = 3\nDimSize = 2 2 1\nElementType = MET_UCHAR\nHeaderSize = -2\nElementDataFile = d.raw\n";
  const std::string msg = test::message_of([&] { read_metaimage(dir / "e.mhd"); });
  EXPECT_NE(msg.find("HeaderSize = -2 is not a list of whole numbers"), std::string::npos) << msg;
}

TEST(Raw, DimsWhoseByteCountOverflowsAreRefused) {
  test::TempDir dir;
  std::ofstream(dir / "empty.raw").flush();
  RawLayout l;
  l.shape = {std::size_t{1} << 32, std::size_t{1} << 32, 1};
  const std::string msg = test::message_of([&] { read_raw(dir / "empty.raw", l); });
  EXPECT_NE(msg.find("more bytes than a 64-bit size counts"), std::string::npos) << "a 2^32 x 2^32 x 1 volume matched an empty file: " << msg;
}

// Headers declaring far more pixels than their files hold (tests/fuzz/regression): refused before
// the volume is allocated (the TIFF used to zero-fill 16 GB, the PNG to throw bad_alloc).
TEST(Tiff, AHeaderDeclaringMoreThanTheFileHoldsIsRefused) {
  const fs::path f = fs::path(GRAINTWIN_SOURCE_DIR) / "tests/fuzz/regression/tiff/header_declares_16_gb";
  const std::string msg = test::message_of([&] { read_tiff(f); });
  EXPECT_NE(msg.find("declares 1 pages of 65535 x 65535 uint32 pixels"), std::string::npos) << msg;
  EXPECT_NE(msg.find("truncated or damaged"), std::string::npos) << msg;
}

TEST(Slices, APngHeaderDeclaringATerapixelIsRefused) {
  const fs::path f = fs::path(GRAINTWIN_SOURCE_DIR) / "tests/fuzz/regression/png/header_declares_a_terapixel";
  const std::string msg = test::message_of([&] { read_png(f); });
  EXPECT_NE(msg.find("declares 1000000 x 1000000 pixels"), std::string::npos) << msg;
}

TEST(Raw, ReadsBigEndianAfterAHeader) {
  test::TempDir dir;
  {
    std::ofstream f(dir / "x.raw", std::ios::binary);
    f.write("HDR!", 4);
    for (std::uint16_t i = 0; i < 8; ++i) {
      const unsigned char b[2] = {static_cast<unsigned char>(i >> 8), static_cast<unsigned char>(i & 0xff)};
      f.write(reinterpret_cast<const char*>(b), 2);
    }
  }
  RawLayout l;
  l.shape = {2, 2, 2};
  l.dtype = DType::uint16;
  l.big_endian = true;
  l.header_bytes = 4;
  const AnyVolume v = read_raw(dir / "x.raw", l);
  const auto& u = std::get<Volume<std::uint16_t>>(v);
  EXPECT_EQ(u(1, 1, 1), 7);
  l.header_bytes = 0;
  EXPECT_THROW(read_raw(dir / "x.raw", l), DataError);  // 18 bytes, 16 expected
}
