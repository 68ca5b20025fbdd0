// io/table_checks: columns of one table agree in length; values no tool writes (NaN where a number
// is the only meaning, infinity anywhere) are refused naming the file, the column and the row.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/table_checks.hpp"
#include "support/errors.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::io;

namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// A /grains table of three rows: centroid (3 x 3), volume (3), label (3), a per-grain note, its
/// options as JSON beside it and a subgroup of another length.
std::filesystem::path write_table(const test::TempDir& dir, const std::string& name, std::vector<double> centroid,
                                  std::vector<double> volume) {
  const auto path = dir / name;
  H5File f = H5File::create(path);
  f.write("/grains/centroid", centroid.data(), {centroid.size() / 3, 3});
  f.write("/grains/volume", volume);
  f.write("/grains/label", std::vector<std::uint32_t>{1, 2, 3});
  f.write_strings("/grains/note", {"a", "b", "c"});
  f.write_strings("/grains/parameters", {"{}"});
  f.write("/grains/rose/counts", std::vector<std::uint64_t>{1, 2, 3, 4, 5});
  return path;
}

const std::vector<double> kCentroid{0, 0, 0, 1, 1, 1, 2, 2, 2};

}  // namespace

TEST(TableChecks, RowsAreTheColumnsCommonLengthBesideSubgroupsAndParameters) {
  test::TempDir dir;
  const H5File f = H5File::open(write_table(dir, "t.h5", kCentroid, {1, 2, 3}));
  EXPECT_EQ(table_rows(f, "/grains", "fix"), 3u);
  EXPECT_EQ(table_rows(f, "/absent", "fix"), 0u);
}

TEST(TableChecks, ColumnsOfDifferentLengthsAreRefusedNamingBoth) {
  test::TempDir dir;
  const auto path = write_table(dir, "short.h5", kCentroid, {1, 2});
  const H5File f = H5File::open(path);
  EXPECT_EQ(test::message_of([&] { table_rows(f, "/grains", "rewrite it with ct2labels"); }),
            path.string() + ": the table /grains has columns of different lengths (/grains/centroid has 3 rows, "
                            "/grains/volume has 2); rewrite it with ct2labels");
}

TEST(TableChecks, InfinityIsRefusedEverywhereNanOnlyWhereNamed) {
  test::TempDir dir;
  const H5File clean = H5File::open(write_table(dir, "clean.h5", kCentroid, {1, 2, 3}));
  EXPECT_EQ(test::message_of([&] { require_finite_table(clean, "/grains", {"centroid", "volume"}, "fix"); }), "");

  // NaN is "not measured" unless the column is named.
  const auto nan_path = write_table(dir, "nan.h5", {0, 0, 0, 1, kNan, 1, 2, 2, 2}, {1, 2, 3});
  const H5File nan = H5File::open(nan_path);
  EXPECT_EQ(test::message_of([&] { require_finite_table(nan, "/grains", {"volume"}, "fix"); }), "");
  EXPECT_EQ(test::message_of([&] { require_finite_table(nan, "/grains", {"centroid"}, "rewrite it with ct2labels"); }),
            nan_path.string() + ": /grains/centroid holds NaN in row 1, a value no GrainTwin tool writes there; rewrite it with ct2labels");

  const auto inf_path = write_table(dir, "inf.h5", kCentroid, {1, 2, -kInf});
  const H5File inf = H5File::open(inf_path);
  EXPECT_EQ(test::message_of([&] { require_finite_table(inf, "/grains", {}, "fix"); }),
            inf_path.string() + ": /grains/volume holds -infinity in row 2, a value no GrainTwin tool writes there; fix");
}

TEST(TableChecks, RequireFiniteNamesTheRowOfTheFirstBadValue) {
  test::TempDir dir;
  const H5File f = H5File::open(write_table(dir, "t.h5", kCentroid, {1, 2, 3}));
  const std::vector<double> rows{0, 0, 0, 1, 1, 1, 2, 2, kInf};
  EXPECT_NE(test::message_of([&] { require_finite(f, "/grains/centroid", rows, 3, "fix"); }).find("holds infinity in row 2"),
            std::string::npos);
  EXPECT_EQ(test::message_of([&] { require_finite(f, "/grains/centroid", kCentroid, 3, "fix"); }), "");
}
