// HDF5 layer: datasets, attributes, compression, strings, provenance, kind checks; a file's
// description (volinfo's stage).
#include <gtest/gtest.h>

#include <fstream>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/io/file_info.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/errors.hpp"
#include "support/fixtures.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::io;

TEST(H5File, RoundTripsTablesAttributesAndStrings) {
  test::TempDir dir;
  const auto path = dir / "t.h5";
  {
    H5File f = H5File::create(path);
    write_root_attrs(f, schema::kind::labels);
    std::vector<double> centroid{1, 2, 3, 4, 5, 6};
    DatasetOptions opt;
    opt.units = "m";
    f.write("/grains/centroid", centroid.data(), {2, 3}, opt);
    f.write("/grains/label", std::vector<std::uint32_t>{7, 9});
    f.set_attr("/grains", "note", std::string("two grains"));
    f.write_strings("/text", {"alpha", "béta"});
  }
  const H5File f = H5File::open(path);
  EXPECT_EQ(file_kind(f), "labels");
  EXPECT_EQ(f.attr_int("/", "schema_version"), schema::version);
  std::vector<hsize_t> dims;
  EXPECT_EQ(f.read<double>("/grains/centroid", &dims), (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(dims, (std::vector<hsize_t>{2, 3}));
  EXPECT_EQ(f.attr_string("/grains/centroid", "units"), "m");
  EXPECT_EQ(f.attr_string("/grains", "note"), "two grains");
  EXPECT_EQ(f.read<std::uint32_t>("/grains/label"), (std::vector<std::uint32_t>{7, 9}));
  EXPECT_EQ(f.read_strings("/text"), (std::vector<std::string>{"alpha", "béta"}));
  EXPECT_EQ(f.list("/grains"), (std::vector<std::string>{"centroid", "label"}));
  EXPECT_FALSE(f.exists("/nothing/here"));
}

TEST(H5File, ImagesAreChunkedCompressedAndCarryGeometry) {
  test::TempDir dir;
  auto v = test::ramp_volume<std::uint16_t>({20, 30, 40}, {3e-5, 2e-5, 1e-5});
  v.set_origin({1e-3, 2e-3, 3e-3});
  write_volume_file(dir / "v.h5", v, {"line one"});
  const H5File f = open_kind(dir / "v.h5", schema::kind::volume);
  H5Id ds(H5Dopen2(f.id(), "/volume", H5P_DEFAULT), H5Dclose);
  H5Id plist(H5Dget_create_plist(ds.get()), H5Pclose);
  EXPECT_EQ(H5Pget_layout(plist.get()), H5D_CHUNKED);
  EXPECT_GE(H5Pget_nfilters(plist.get()), 2);  // shuffle + deflate
  const ImageHeader h = read_image_header(f, "/volume");
  EXPECT_EQ(h.shape, (Shape3{20, 30, 40}));
  EXPECT_EQ(h.voxel_size, (Vec3{3e-5, 2e-5, 1e-5}));
  EXPECT_EQ(h.origin, (Vec3{1e-3, 2e-3, 3e-3}));
  EXPECT_EQ(f.attr_string("/volume", "axis_order"), "zyx");
  const auto back = read_image_as<std::uint16_t>(f, "/volume");
  EXPECT_EQ(back.values(), v.values());
  EXPECT_EQ(read_history(f), (std::vector<std::string>{"line one"}));
}

TEST(H5File, ReadBoxReadsASubVolume) {
  test::TempDir dir;
  auto v = test::ramp_volume<float>({6, 7, 8});
  write_volume_file(dir / "v.h5", v, {});
  const H5File f = H5File::open(dir / "v.h5");
  std::vector<float> box(2 * 3 * 4);
  f.read_box("/volume", {1, 2, 3}, {2, 3, 4}, box.data());
  EXPECT_EQ(box[0], v(1, 2, 3));
  EXPECT_EQ(box.back(), v(2, 4, 6));
}

TEST(KindCheck, NamesWhatWasFoundAndWhatToDo) {
  test::TempDir dir;
  write_volume_file(dir / "v.h5", test::ramp_volume<std::uint8_t>({2, 2, 2}), {});
  try {
    open_kind(dir / "v.h5", schema::kind::labels, "pass the output of ct2labels");
    FAIL() << "expected UsageError";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("kind=volume"), std::string::npos);
    EXPECT_NE(e.message().find("expected kind=labels"), std::string::npos);
    EXPECT_NE(e.message().find("ct2labels"), std::string::npos);
  }
}

TEST(KindCheck, RejectsNewerSchemaAndMissingKind) {
  test::TempDir dir;
  {
    H5File f = H5File::create(dir / "new.h5");
    f.set_attr("/", "kind", std::string("volume"));
    f.set_attr("/", "schema_version", 99LL);
    H5File g = H5File::create(dir / "bare.h5");
    g.write("/x", std::vector<double>{1.0});
  }
  EXPECT_THROW(open_kind(dir / "new.h5", "volume"), UsageError);
  EXPECT_THROW(open_kind(dir / "bare.h5", "volume"), UsageError);
}

TEST(KindCheck, NonHdf5FileIsAUsageError) {
  test::TempDir dir;
  std::ofstream(dir / "fake.h5") << "this is not HDF5";
  try {
    H5File::open(dir / "fake.h5");
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("not an HDF5 file"), std::string::npos);
  }
  EXPECT_THROW(H5File::open(dir / "missing.h5"), UsageError);
}

TEST(Provenance, MergeSkipsLinesAlreadyPresent) {
  std::vector<std::string> h{"a", "b"};
  merge_history(h, {"b", "c"});
  EXPECT_EQ(h, (std::vector<std::string>{"a", "b", "c"}));
}

using test::message_of;

TEST(H5File, ADeclaredExtentTheFileDoesNotStoreIsRefusedBeforeAllocating) {
  test::TempDir dir;
  const auto path = dir / "huge.h5";
  {
    // A chunked dataset of 2^40 doubles with no chunk written: HDF5 stores nothing and reads fill values.
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[1] = {hsize_t{1} << 40}, chunk[1] = {64};
    const hid_t space = H5Screate_simple(1, dims, nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 1, chunk);
    H5Dclose(H5Dcreate2(file, "/volume", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT));
    H5Pclose(dcpl), H5Sclose(space), H5Fclose(file);
  }
  const H5File f = H5File::open(path);
  const std::string msg = message_of([&] { f.read<double>("/volume"); });
  EXPECT_NE(msg.find(":/volume: the dataset declares"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1099511627776 values"), std::string::npos) << msg;
  EXPECT_NE(msg.find("truncated or damaged"), std::string::npos) << msg;
}

TEST(H5File, OneValueReadsNameTheMissingOrMiscountedObject) {
  test::TempDir dir;
  const auto path = dir / "t.h5";
  {
    H5File f = H5File::create(path);
    f.write("/sample/void_ratio", std::vector<double>{});
    f.write_strings("/run/parameters", {"{}", "{}"});
    f.set_attr("/sample", "count", std::numeric_limits<double>::quiet_NaN());
    f.set_attr("/sample", "time", std::vector<double>{1.0, 2.0});
  }
  const H5File f = H5File::open(path);
  EXPECT_NE(message_of([&] { f.read_scalar<double>("/sample/void_ratio"); }).find("/sample/void_ratio holds 0 values where one"),
            std::string::npos);
  EXPECT_NE(message_of([&] { f.read_string("/run/parameters"); }).find("holds 2 strings where one"), std::string::npos);
  EXPECT_NE(message_of([&] { f.attr_int("/sample", "count"); }).find("attribute 'count' is nan, not a whole number"),
            std::string::npos);
  EXPECT_NE(message_of([&] { f.attr_double("/sample", "time"); }).find("attribute 'time' is missing or not one number"),
            std::string::npos);
}

TEST(KindCheck, AKindOfThousandsOfCharactersIsQuotedAsAnExcerpt) {
  test::TempDir dir;
  {
    H5File f = H5File::create(dir / "k.h5");
    f.set_attr("/", "kind", std::string(5000, 'x'));
    f.set_attr("/", "schema_version", 1LL);
  }
  const std::string msg = message_of([&] { open_kind(dir / "k.h5", schema::kind::volume); });
  EXPECT_NE(msg.find("kind=" + std::string(60, 'x') + "..., expected kind=volume"), std::string::npos) << msg;
  EXPECT_LT(msg.size(), 300u);
}

TEST(KindCheck, AKindAttributeHoldingSeveralStringsIsRefusedNotOverrun) {
  test::TempDir dir;
  {
    // What h5py writes for attrs["kind"] = ["volume", "labels"]: an array of two strings, which
    // attr_string used to read into room for one (a stack overrun found by the fuzz targets).
    const hid_t file = H5Fcreate((dir / "two.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, H5T_VARIABLE);
    const hsize_t n = 2;
    const hid_t space = H5Screate_simple(1, &n, nullptr);
    const char* values[2] = {"volume", "labels"};
    const hid_t attr = H5Acreate2(file, "kind", type, space, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(attr, type, values);
    H5Aclose(attr), H5Sclose(space), H5Tclose(type), H5Fclose(file);
  }
  const std::string msg = message_of([&] { open_kind(dir / "two.h5", schema::kind::volume); });
  EXPECT_NE(msg.find("attribute 'kind' holds 2 strings where one is expected"), std::string::npos) << msg;
}


TEST(FileInfo, DescribesAFileWithTheValueRangeOnlyWhenAsked) {
  test::TempDir dir;
  const auto v = test::ramp_volume<std::uint16_t>({3, 4, 5});
  write_volume_file(dir / "v.h5", v, {"a ramp"});
  const nlohmann::json plain = describe_file(dir / "v.h5", false);
  EXPECT_EQ(plain["kind"], "volume");
  ASSERT_EQ(plain["images"].size(), 1u);
  EXPECT_FALSE(plain["images"][0].contains("min"));
  std::vector<std::string> steps;
  double last = 0.0;
  const nlohmann::json ranged = describe_file(dir / "v.h5", true, [&](const std::string& step) {
    steps.push_back(step);
    return std::function<void(double)>([&](double share) { last = share; });
  });
  EXPECT_EQ(steps, std::vector<std::string>{"value range /volume"});
  EXPECT_EQ(last, 1.0);
  const ValueRange whole = value_range(AnyVolume(v));
  EXPECT_EQ(ranged["images"][0]["min"].get<double>(), whole.min);
  EXPECT_EQ(ranged["images"][0]["max"].get<double>(), whole.max);
  EXPECT_DOUBLE_EQ(ranged["images"][0]["mean"].get<double>(), whole.mean);
  const std::string text = describe_text(ranged);
  EXPECT_NE(text.find("kind:            volume"), std::string::npos) << text;
  EXPECT_NE(text.find("  values:          "), std::string::npos) << text;
  EXPECT_NE(text.find("history:\n  a ramp\n"), std::string::npos) << text;
  { H5File bare = H5File::create(dir / "bare.h5"); }
  EXPECT_THROW(describe_file(dir / "bare.h5", false), UsageError);
}
