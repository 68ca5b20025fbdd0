// Label clean-up and the grain table: sequential relabelling, fragments merged by largest boundary
// or removed, edge grains, exact table entries, thread independence.
#include <gtest/gtest.h>
#include <omp.h>

#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "support/errors.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

void fill_box(Volume<std::uint32_t>& l, std::uint32_t v, Shape3 lo, Shape3 hi) {
  for (std::size_t z = lo[0]; z < hi[0]; ++z)
    for (std::size_t y = lo[1]; y < hi[1]; ++y)
      for (std::size_t x = lo[2]; x < hi[2]; ++x) l(z, y, x) = v;
}

}  // namespace

TEST(Relabel, NumbersLabelsByFirstVoxelInRasterOrder) {
  Volume<std::uint32_t> l({1, 2, 4});
  l.values() = {0, 7, 3, 7, 0, 100, 3, 0};
  EXPECT_EQ(relabel_sequential(l), 3u);
  EXPECT_EQ(l.values(), (std::vector<std::uint32_t>{0, 1, 2, 1, 0, 3, 2, 0}));
  // Label values far above the voxel count take the sparse path with the same result.
  l.values() = {0, 4000000000u, 3, 4000000000u, 0, 100, 3, 0};
  EXPECT_EQ(relabel_sequential(l), 3u);
  EXPECT_EQ(l.values(), (std::vector<std::uint32_t>{0, 1, 2, 1, 0, 3, 2, 0}));
}

TEST(Fragments, MergeIntoTheNeighbourWithTheLargestBoundary) {
  Volume<std::uint32_t> l({3, 10, 12});
  fill_box(l, 1, {0, 0, 0}, {3, 6, 5});   // grain 1: x 0..4, y 0..5
  fill_box(l, 2, {0, 0, 7}, {3, 6, 12});  // grain 2: x 7..11, y 0..5
  // Fragment 3 (3 voxels) at x = 5..6: touches grain 1 by 1 face, grain 2 by 2 faces.
  l(1, 2, 5) = 3;
  l(1, 2, 6) = 3;
  l(1, 3, 6) = 3;
  // Fragment 4: isolated beyond the grains.
  l(1, 8, 5) = 4;
  const auto before = l;
  const FragmentReport r = remove_small_fragments(l, 5, FragmentPolicy::merge, Connectivity::faces);
  EXPECT_EQ(r.merged, 1u);
  EXPECT_EQ(r.removed, 1u);
  EXPECT_EQ(l(1, 2, 5), 2u);
  EXPECT_EQ(l(1, 3, 6), 2u);
  EXPECT_EQ(l(1, 8, 5), 0u);
  for (std::size_t i = 0; i < l.size(); ++i) {
    if (before.values()[i] == 1 || before.values()[i] == 2) {
      EXPECT_EQ(l.values()[i], before.values()[i]);
    }
  }
}

TEST(Fragments, ChainsOfFragmentsMergeUntilLargeEnough) {
  Volume<std::uint32_t> l({1, 6, 20});
  fill_box(l, 1, {0, 0, 0}, {1, 6, 8});  // a big grain, x 0..7
  // Fragment 5 (2 voxels) touches grain 1 by 1 face and fragment 6 by 2 faces; fragment 6 (3
  // voxels) touches only fragment 5. With min 4: 5 (smallest) joins 6; 6 (now 5 voxels) is large.
  l(0, 0, 8) = 5;
  l(0, 1, 9) = 5;
  l(0, 0, 9) = 6;
  l(0, 0, 10) = 6;
  l(0, 1, 10) = 6;
  const FragmentReport r = remove_small_fragments(l, 4, FragmentPolicy::merge, Connectivity::faces);
  EXPECT_EQ(r.merged, 1u);
  EXPECT_EQ(r.removed, 0u);
  EXPECT_EQ(l(0, 0, 8), 6u);
  EXPECT_EQ(l(0, 1, 9), 6u);
  EXPECT_EQ(l(0, 0, 0), 1u);
  // With a minimum of 7 the merged pair (5 voxels) is still small and joins grain 1, its only
  // remaining neighbour.
  Volume<std::uint32_t> m({1, 6, 20});
  fill_box(m, 1, {0, 0, 0}, {1, 6, 8});
  m(0, 0, 8) = 5, m(0, 1, 9) = 5, m(0, 0, 9) = 6, m(0, 0, 10) = 6, m(0, 1, 10) = 6;
  const FragmentReport r2 = remove_small_fragments(m, 7, FragmentPolicy::merge, Connectivity::faces);
  EXPECT_EQ(r2.merged, 2u);
  for (std::size_t x : {8u, 9u, 10u}) EXPECT_EQ(m(0, 0, x), 1u);
}

TEST(Fragments, RemovePolicyAndConnectivity) {
  Volume<std::uint32_t> l({3, 3, 3});
  fill_box(l, 1, {0, 0, 0}, {1, 3, 3});
  l(2, 2, 2) = 2;  // touches nothing
  l(1, 1, 1) = 3;  // touches grain 1 by a face
  auto removed = l;
  const auto r = remove_small_fragments(removed, 2, FragmentPolicy::remove);
  EXPECT_EQ(r.removed, 2u);
  EXPECT_EQ(std::count(removed.values().begin(), removed.values().end(), 0u), 27 - 9);
  // Diagonal contact only: a neighbour under 26-connectivity, isolated under 6.
  Volume<std::uint32_t> d({2, 2, 2});
  d(0, 0, 0) = 1, d(0, 0, 1) = 1, d(0, 1, 0) = 1, d(1, 1, 1) = 2;
  auto d6 = d;
  remove_small_fragments(d6, 2, FragmentPolicy::merge, Connectivity::faces);
  EXPECT_EQ(d6(1, 1, 1), 0u);
  remove_small_fragments(d, 2, FragmentPolicy::merge, Connectivity::corners);
  EXPECT_EQ(d(1, 1, 1), 1u);
  Volume<std::uint32_t> huge({1, 1, 2});
  huge(0, 0, 0) = 50;
  EXPECT_THROW(remove_small_fragments(huge, 2), UsageError);
}

TEST(EdgeGrains, RemovesLabelsOnAnyFace) {
  Volume<std::uint32_t> l({5, 5, 5});
  l(2, 2, 2) = 1;
  l(0, 2, 2) = 2;
  l(2, 4, 2) = 3;
  l(2, 2, 0) = 4;
  l(1, 2, 2) = 2;  // interior voxel of an edge grain goes too
  EXPECT_EQ(remove_edge_grains(l), 3u);
  EXPECT_EQ(l(2, 2, 2), 1u);
  EXPECT_EQ(l(1, 2, 2), 0u);
  EXPECT_EQ(std::count(l.values().begin(), l.values().end(), 0u), 124);
}

TEST(GrainTable, ExactCountsCentroidsBoxesAndVolumes) {
  Volume<std::uint32_t> l({6, 7, 8}, {3e-5, 2e-5, 1e-5}, {1e-3, 2e-3, 3e-3});
  fill_box(l, 2, {1, 2, 3}, {3, 5, 7});  // 2 x 3 x 4 box
  l(5, 6, 7) = 5;                        // a corner voxel
  const auto t = grain_table(l);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].label, 2u);
  EXPECT_EQ(t[0].voxels, 24u);
  EXPECT_DOUBLE_EQ(t[0].volume_m3, 24 * 6e-15);
  EXPECT_DOUBLE_EQ(t[0].centroid_xyz[0], 3e-3 + 4.5 * 1e-5);  // x: indices 3..6
  EXPECT_DOUBLE_EQ(t[0].centroid_xyz[1], 2e-3 + 3.0 * 2e-5);  // y: 2..4
  EXPECT_DOUBLE_EQ(t[0].centroid_xyz[2], 1e-3 + 1.5 * 3e-5);  // z: 1..2
  EXPECT_EQ(t[0].bbox, (std::array<std::size_t, 6>{1, 2, 3, 3, 5, 7}));
  EXPECT_FALSE(t[0].touches_edge);
  EXPECT_EQ(t[1].label, 5u);
  EXPECT_TRUE(t[1].touches_edge);
  EXPECT_EQ(t[1].bbox, (std::array<std::size_t, 6>{5, 6, 7, 6, 7, 8}));
}

TEST(GrainTable, SameWithOneAndTwoThreads) {
  std::mt19937 rng(2);
  Volume<std::uint32_t> l({30, 31, 32});
  for (auto& v : l.values()) v = rng() % 50;
  omp_set_num_threads(1);
  const auto one = grain_table(l);
  omp_set_num_threads(2);
  const auto two = grain_table(l);
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i].voxels, two[i].voxels);
    EXPECT_EQ(one[i].centroid_xyz, two[i].centroid_xyz);
    EXPECT_EQ(one[i].bbox, two[i].bbox);
  }
}

TEST(GrainTable, MismatchNamesMissingExtraAndDisagreeingRows) {
  Volume<std::uint32_t> l({6, 7, 8});
  fill_box(l, 1, {0, 0, 0}, {2, 2, 2});
  fill_box(l, 2, {3, 3, 3}, {5, 5, 5});
  fill_box(l, 3, {0, 4, 5}, {1, 6, 8});
  fill_box(l, 4, {4, 0, 6}, {6, 2, 8});
  const auto table = grain_table(l);
  EXPECT_EQ(grain_table_mismatch(l, table), "");

  auto short_table = table;
  short_table.resize(2);
  EXPECT_EQ(grain_table_mismatch(l, short_table), "2 grains of the label image have no row in the grain table (labels 3 to 4)");
  auto extra = table;
  extra.push_back(table.back());
  extra.back().label = 9;
  EXPECT_EQ(grain_table_mismatch(l, extra), "1 row names a label absent from the label image (first: label 9)");
  auto wrong = table;
  wrong[1].voxels = 7;
  wrong[2].bbox[0] = 1;
  EXPECT_EQ(grain_table_mismatch(l, wrong),
            "2 rows disagree with the image (first: label 2 has 7 voxels in the table but 8 in the image)");
  auto moved = table;
  moved[3].centroid_xyz[0] += 0.5 * l.voxel_size()[2];
  EXPECT_NE(grain_table_mismatch(l, moved).find("label 4's centroid is not the mean of its voxels"), std::string::npos);
  auto unsorted = table;
  std::swap(unsorted[0], unsorted[1]);
  EXPECT_EQ(grain_table_mismatch(l, unsorted), "its rows are not in increasing label order (label 1 follows 2)");
  // Every kind at once, in one sentence.
  short_table.push_back(table[3]);
  short_table.back().label = 5;
  EXPECT_EQ(grain_table_mismatch(l, short_table),
            "2 grains of the label image have no row in the grain table (labels 3 to 4) and 1 row names a label absent "
            "from the label image (first: label 5)");
  // Labels beyond the voxel count cannot be a numbered grain table's.
  l(0, 0, 0) = 4000000000u;
  EXPECT_NE(grain_table_mismatch(l, table).find("label 4000000000, more than its 336 voxels"), std::string::npos);
}

TEST(LabelsFile, ReadingRefusesAGrainTableThatDisagreesWithTheImage) {
  test::TempDir dir;
  LabelsFile c;
  c.labels = Volume<std::uint32_t>({5, 5, 5});
  fill_box(c.labels, 1, {0, 0, 0}, {2, 2, 2});
  fill_box(c.labels, 2, {3, 3, 3}, {5, 5, 5});
  c.grains = grain_table(c.labels);
  c.parameters_json = "{}";
  write_labels_file(dir / "good.h5", c, {"test"});
  EXPECT_EQ(read_labels_file(dir / "good.h5").grains.size(), 2u);
  c.grains.pop_back();
  write_labels_file(dir / "short.h5", c, {"test"});
  try {
    read_labels_file(dir / "short.h5");
    FAIL() << "a grain without a row was accepted";
  } catch (const DataError& e) {
    EXPECT_EQ(e.message(), "the grain table of " + (dir / "short.h5").string() +
                               " does not match its label image: 1 grain of the label image has no row in the grain "
                               "table (label 2); rewrite the file with ct2labels");
  }
}

TEST(LabelsFile, ReadingRefusesANonFiniteCentroid) {
  test::TempDir dir;
  LabelsFile c;
  c.labels = Volume<std::uint32_t>({5, 5, 5});
  fill_box(c.labels, 1, {0, 0, 0}, {2, 2, 2});
  c.grains = grain_table(c.labels);
  c.grains[0].centroid_xyz[1] = std::numeric_limits<double>::quiet_NaN();
  c.parameters_json = "{}";
  write_labels_file(dir / "nan.h5", c, {"test"});
  EXPECT_EQ(test::message_of([&] { read_labels_file(dir / "nan.h5"); }),
            (dir / "nan.h5").string() + ": /grains/centroid holds NaN in row 0, a value no GrainTwin tool writes there; "
                                        "rewrite it with ct2labels");
}
