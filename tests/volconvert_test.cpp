// volconvert: CLI contract, bit-exact round trips through every format, and every bad input.
#include <gtest/gtest.h>

#include <fstream>

#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/tiff.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/cli_contract.hpp"
#include "support/fixtures.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using test::run_tool;
namespace fs = std::filesystem;

namespace {
const fs::path soil_mhd = fs::path(GRAINTWIN_SOURCE_DIR) / ".." / "shared" / "real_data" / "emsl_soil_core_xct" /
                          "bean_bucket_soil_crop_100x256x256_u8.mhd";

std::vector<char> file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
}  // namespace

TEST(Volconvert, StandardCli) { test::expect_standard_cli("volconvert"); }

TEST(Volconvert, MissingInputIsAUsageErrorNamingIt) {
  test::TempDir dir;
  const auto r = run_tool("volconvert", {(dir / "nope.tif").string(), (dir / "o.h5").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope.tif"), std::string::npos);
  EXPECT_EQ(test::list_dir(dir.path()).size(), 0u);
}

TEST(Volconvert, ExistingOutputIsRefusedAndLeftUntouched) {
  test::TempDir dir;
  const auto mhd = test::write_mhd(dir.path(), "v", test::ramp_volume<std::uint8_t>({2, 3, 4}));
  std::ofstream(dir / "out.h5") << "keep me";
  auto r = run_tool("volconvert", {mhd.string(), (dir / "out.h5").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--force"), std::string::npos);
  EXPECT_EQ(file_bytes(dir / "out.h5"), (std::vector<char>{'k', 'e', 'e', 'p', ' ', 'm', 'e'}));
  r = run_tool("volconvert", {mhd.string(), (dir / "out.h5").string(), "--force"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(io::file_kind(io::H5File::open(dir / "out.h5")), "volume");
}

TEST(Volconvert, RealSoilCropRoundTripsBitExact) {
  ASSERT_TRUE(fs::exists(soil_mhd)) << soil_mhd;
  test::TempDir dir;
  auto r = run_tool("volconvert", {soil_mhd.string(), (dir / "soil.h5").string(), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "-q must silence everything but errors: " << r.err;
  const auto raw = file_bytes(soil_mhd.parent_path() / "bean_bucket_soil_crop_100x256x256_u8.raw");
  const AnyVolume h5 = io::read_volume_file(dir / "soil.h5");
  const auto& u8 = std::get<Volume<std::uint8_t>>(h5);
  ASSERT_EQ(u8.shape(), (Shape3{100, 256, 256}));
  EXPECT_TRUE(std::equal(raw.begin(), raw.end(), reinterpret_cast<const char*>(u8.data())));
  EXPECT_NEAR(u8.voxel_size()[0], 60.7e-6, 1e-12);

  r = run_tool("volconvert", {(dir / "soil.h5").string(), (dir / "soil.tif").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_tool("volconvert", {(dir / "soil.tif").string(), (dir / "soil2.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const AnyVolume back = io::read_volume_file(dir / "soil2.h5");
  EXPECT_TRUE(test::same_voxels(h5, back));
  EXPECT_EQ(std::get<Volume<std::uint8_t>>(back).voxel_size(), u8.voxel_size());
}

TEST(Volconvert, ProvenanceIsCopiedAndAppended) {
  test::TempDir dir;
  const auto mhd = test::write_mhd(dir.path(), "v", test::ramp_volume<std::uint16_t>({8, 8, 8}));
  ASSERT_EQ(run_tool("volconvert", {mhd.string(), (dir / "a.h5").string()}).exit_code, 0);
  ASSERT_EQ(run_tool("volconvert", {(dir / "a.h5").string(), (dir / "b.h5").string(), "--crop", "1:7,:,:"}).exit_code, 0);
  const auto h = io::read_history(io::H5File::open(dir / "b.h5"));
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h[0].rfind("volconvert " + mhd.string(), 0), 0u);
  EXPECT_NE(h[1].find("--crop 1:7,:,:"), std::string::npos);
  EXPECT_NE(h[1].find("graintwin 0."), std::string::npos);
}

TEST(Volconvert, CropDownsampleAndCast) {
  test::TempDir dir;
  auto v = test::ramp_volume<float>({8, 8, 8}, {1e-5, 1e-5, 1e-5});
  v(2, 0, 4) = -5000.0f;  // survives crop and block mean as a negative value, so the cast clamps
  io::write_volume_file(dir / "f.h5", v, {});
  auto r = run_tool("volconvert", {(dir / "f.h5").string(), (dir / "o.h5").string(), "--crop", "2:6,:,-4:",
                                   "--downsample", "2", "--cast", "uint8"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("clamped"), std::string::npos);  // negative ramp values
  const AnyVolume out = io::read_volume_file(dir / "o.h5");
  const auto& o = std::get<Volume<std::uint8_t>>(out);
  EXPECT_EQ(o.shape(), (Shape3{2, 4, 2}));
  EXPECT_DOUBLE_EQ(o.voxel_size()[0], 2e-5);
}

TEST(Volconvert, RawWithDimsAndSliceFolders) {
  test::TempDir dir;
  auto v = test::ramp_volume<std::uint16_t>({3, 4, 5});
  {
    std::ofstream f(dir / "x.raw", std::ios::binary);
    f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * 2));
  }
  auto r = run_tool("volconvert", {(dir / "x.raw").string(), (dir / "x.h5").string(), "--dims", "3,4,5",
                                   "--dtype", "uint16", "--voxel-size", "10um"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(test::same_voxels(io::read_volume_file(dir / "x.h5"), v));

  fs::create_directory(dir / "slices");
  for (std::size_t z = 0; z < 3; ++z) {
    Volume<std::uint16_t> s({1, 4, 5});
    std::copy(&v(z, 0, 0), &v(z, 0, 0) + 20, s.data());
    io::write_tiff(dir / "slices" / ("s" + std::to_string(z) + ".tif"), s);
  }
  r = run_tool("volconvert", {(dir / "slices").string(), (dir / "s.h5").string()});
  EXPECT_EQ(r.exit_code, 2) << "slices carry no z spacing";
  EXPECT_NE(r.err.find("--voxel-size"), std::string::npos);
  r = run_tool("volconvert", {(dir / "slices" / "s*.tif").string(), (dir / "s.h5").string(), "--voxel-size", "10um"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(test::same_voxels(io::read_volume_file(dir / "s.h5"), v));
}

struct BadInput {
  std::string name;
  std::function<std::vector<std::string>(const test::TempDir&)> setup;  // returns the arguments
  int exit_code;
  std::string says;
};

void PrintTo(const BadInput& c, std::ostream* os) { *os << c.name; }

class VolconvertBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(VolconvertBadInput, FailsClearlyAndWritesNothing) {
  const BadInput& c = GetParam();
  test::TempDir dir;
  auto args = c.setup(dir);
  const auto before = test::list_dir(dir.path());
  args.push_back((dir / "out.h5").string());
  const auto r = run_tool("volconvert", args);
  EXPECT_EQ(r.exit_code, c.exit_code) << r.err;
  EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  EXPECT_EQ(test::list_dir(dir.path()), before) << "a failing run must leave no output";
}

INSTANTIATE_TEST_SUITE_P(
    Cases, VolconvertBadInput,
    ::testing::Values(
        BadInput{"truncated_raw",
                 [](const test::TempDir& d) {
                   std::ofstream(d / "t.raw", std::ios::binary) << std::string(50, 'x');
                   return std::vector<std::string>{(d / "t.raw").string(), "--dims", "2,5,6", "--dtype", "uint8",
                                                   "--voxel-size", "1um"};
                 },
                 1, "needs 60"},
        BadInput{"mhd_size_mismatch",
                 [](const test::TempDir& d) {
                   const auto m = test::write_mhd(d.path(), "m", test::ramp_volume<std::uint16_t>({2, 3, 4}));
                   fs::resize_file(d / "m.raw", 40);
                   return std::vector<std::string>{m.string()};
                 },
                 1, "DimSize"},
        BadInput{"empty_slice_folder",
                 [](const test::TempDir& d) {
                   fs::create_directory(d / "empty");
                   return std::vector<std::string>{(d / "empty").string(), "--voxel-size", "1um"};
                 },
                 2, "no .tif"},
        BadInput{"unknown_kind",
                 [](const test::TempDir& d) {
                   io::H5File f = io::H5File::create(d / "l.h5");
                   io::write_root_attrs(f, schema::kind::labels);
                   return std::vector<std::string>{(d / "l.h5").string()};
                 },
                 2, "kind=labels"},
        BadInput{"not_hdf5",
                 [](const test::TempDir& d) {
                   std::ofstream(d / "fake.h5") << "PNG pretending to be HDF5";
                   return std::vector<std::string>{(d / "fake.h5").string()};
                 },
                 2, "not an HDF5 file"},
        BadInput{"text_named_tif",
                 [](const test::TempDir& d) {
                   std::ofstream(d / "text.tif") << "not a tiff";
                   return std::vector<std::string>{(d / "text.tif").string()};
                 },
                 1, "not a readable TIFF"},
        BadInput{"bad_crop",
                 [](const test::TempDir& d) {
                   const auto m = test::write_mhd(d.path(), "m", test::ramp_volume<std::uint8_t>({2, 3, 4}));
                   return std::vector<std::string>{m.string(), "--crop", "5:9,:,:"};
                 },
                 2, "selects nothing"},
        BadInput{"bad_cast_type",
                 [](const test::TempDir& d) {
                   const auto m = test::write_mhd(d.path(), "m", test::ramp_volume<std::uint8_t>({2, 3, 4}));
                   return std::vector<std::string>{m.string(), "--cast", "int7"};
                 },
                 2, "unknown data type"},
        // 128 x 144115188075856997 x 1 uint16 wraps round to a small byte count in 64 bits: a file of
        // that size passed the size check and --crop ran off the volume (SIGSEGV).
        BadInput{"dims_beyond_64_bits",
                 [](const test::TempDir& d) {
                   const std::uint64_t wrapped = 128ull * 144115188075856997ull * 2ull;  // unsigned: wraps, defined
                   std::ofstream(d / "big.raw", std::ios::binary) << std::string(wrapped, '\0');
                   return std::vector<std::string>{(d / "big.raw").string(), "--dims", "128,144115188075856997,1", "--dtype",
                                                   "uint16", "--crop", "0:2,0:1000,:", "--voxel-size", "1um"};
                 },
                 2, "describes a volume of 1.84e+19 voxels, beyond what a 64-bit size can count"},
        BadInput{"dims_not_whole_numbers",
                 [](const test::TempDir& d) {
                   std::ofstream(d / "t.raw", std::ios::binary) << std::string(60, 'x');
                   return std::vector<std::string>{(d / "t.raw").string(), "--dims", "2,5,6x", "--voxel-size", "1um"};
                 },
                 2, "'6x' is not a positive integer"},
        BadInput{"negative_header_bytes",
                 [](const test::TempDir& d) {
                   std::ofstream(d / "t.raw", std::ios::binary) << std::string(60, 'x');
                   return std::vector<std::string>{(d / "t.raw").string(), "--dims", "2,5,6", "--header-bytes", "-1"};
                 },
                 2, "--header-bytes: must be a whole number in [0, 1.1259e+15] bytes, not -1"},
        BadInput{"voxel_size_nan",
                 [](const test::TempDir& d) {
                   const auto m = test::write_mhd(d.path(), "m", test::ramp_volume<std::uint8_t>({2, 3, 4}));
                   return std::vector<std::string>{m.string(), "--voxel-size", "nan"};
                 },
                 2, "--voxel-size: the length 'nan' must be a finite length"},
        BadInput{"downsample_beyond_range",
                 [](const test::TempDir& d) {
                   const auto m = test::write_mhd(d.path(), "m", test::ramp_volume<std::uint8_t>({2, 3, 4}));
                   return std::vector<std::string>{m.string(), "--downsample", "1e12"};
                 },
                 2, "--downsample: must be a whole number in [1, 1000]"}),
    [](const ::testing::TestParamInfo<BadInput>& i) { return i.param.name; });

TEST(Volconvert, ThreePageTiffBecomesThreeSlices) {
  test::TempDir dir;
  io::write_tiff(dir / "three.tif", test::ramp_volume<std::uint8_t>({3, 10, 12}));
  const auto r = run_tool("volconvert", {(dir / "three.tif").string(), (dir / "o.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(shape_of_any(io::read_volume_file(dir / "o.h5")), (Shape3{3, 10, 12}));
}

// A raw file larger than the memory the process may use is refused from its size, before the
// allocation that would fail (or be killed): here a sparse 3 GB file under a 2 GB address-space limit.
TEST(Volconvert, RawLargerThanTheMemoryIsRefusedWithTheNumbers) {
  test::TempDir dir;
  { std::ofstream(dir / "huge.raw", std::ios::binary); }
  fs::resize_file(dir / "huge.raw", 3000000000ull);  // sparse: no disk space used
  const auto before = test::list_dir(dir.path());
  const auto r = test::run_tool_with_memory_limit("volconvert", 2000000000,
                                                  {(dir / "huge.raw").string(), (dir / "out.h5").string(), "--dims", "1000,1000,1500",
                                                   "--dtype", "uint16", "--voxel-size", "1um"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("huge.raw needs about 3 GB for 1000 x 1000 x 1500 uint16 voxels, more than the 2 GB of the "
                       "address-space limit (ulimit -v); convert it on a machine with more memory"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(test::list_dir(dir.path()), before);
}
