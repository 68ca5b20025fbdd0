// The whole ct2labels chain (segment_grains), the labels file and the preview overlay, on sphere
// phantoms whose grains are known exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/preview.hpp"
#include "graintwin/segment/segment_grains.hpp"
#include "graintwin/segment/threshold.hpp"
#include "graintwin/validate/label_match.hpp"
#include "support/golden.hpp"
#include "support/phantoms.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::segment;
using test::Ball;

namespace {

const std::vector<Ball> kBalls = test::jittered_lattice(3, 7.0, 13.0, 9.0, 0.8, 0.05, 11);
const Shape3 kShape{44, 44, 44};

/// Share of the true grains reproduced, by the one scoring rule of segmentation (IoU >= 0.8).
double matched_share(const Volume<std::uint32_t>& truth, const Volume<std::uint32_t>& got) {
  return validate::match_labels(truth, got).matched_share();
}

template <class T>
Volume<T> constant(T value) {
  Volume<T> v({8, 8, 8}, {1e-5, 1e-5, 1e-5});
  for (auto& x : v.values()) x = value;
  return v;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.message();
  }
  return "";
}

}  // namespace

TEST(SegmentGrains, DefaultsFindEverySphereOfANoisyScan) {
  const Volume<float> grey = test::scan_balls(kShape, kBalls, 5, 0.03);
  SegmentOptions o;
  o.region_mode = RegionMode::whole_volume;
  std::vector<std::string> steps;
  o.on_step = [&](const std::string& s) { steps.push_back(s); };
  const SegmentResult r = segment_grains(grey, o);
  EXPECT_EQ(r.grains.size(), kBalls.size());
  EXPECT_EQ(r.markers, kBalls.size());
  EXPECT_TRUE(r.threshold_from_otsu);
  EXPECT_NEAR(r.threshold, 0.5, 0.1);  // grey 0.25 void, 0.75 grain
  EXPECT_TRUE(r.marker_parameter_automatic);
  ASSERT_TRUE(r.h_proposal.has_value());
  EXPECT_EQ(r.marker_parameter_vox, r.h_proposal->h_vox);
  EXPECT_NEAR(r.reference_radius_m, 7e-5, 2e-5);
  EXPECT_DOUBLE_EQ(matched_share(test::label_balls(kShape, kBalls), r.labels), 1.0);
  EXPECT_EQ(steps.front(), "denoise");
  EXPECT_EQ(steps.back(), "grain table");
  // The grain table is the one of the labels, numbered 1..N.
  for (std::size_t i = 0; i < r.grains.size(); ++i) EXPECT_EQ(r.grains[i].label, i + 1);
  // Whole-volume void ratio from exact voxel counts of the final mask.
  EXPECT_NEAR(r.void_ratio.e, (1.0 - r.solid_fraction) / r.solid_fraction, 1e-12);
  test::Golden measured("segment_grains");
  measured.check("defaults_otsu_threshold", r.threshold);
  measured.check("defaults_reference_radius_over_true", r.reference_radius_m / 7e-5);
  measured.check("defaults_void_ratio", r.void_ratio.e);
}

TEST(SegmentGrains, EveryMarkerAndDenoiseChoiceAgreesOnTheSpheres) {
  const Volume<float> grey = test::scan_balls(kShape, kBalls, 6, 0.03);
  const auto truth = test::label_balls(kShape, kBalls);
  for (int variant = 0; variant < 4; ++variant) {
    SegmentOptions o;
    o.region_mode = RegionMode::whole_volume;
    if (variant == 0) o.markers = MarkerMethod::peaks, o.expected_d50_m = 14e-5;
    if (variant == 1) o.denoise = Denoise::gaussian, o.h_vox = 1.0;
    if (variant == 2) o.denoise = Denoise::none, o.threshold = 0.5, o.connectivity = Connectivity::faces;
    if (variant == 3) o.fragments = FragmentPolicy::remove, o.min_volume_vox = 50.0, o.open_radius_vox = 1.0;
    const SegmentResult r = segment_grains(grey, o);
    EXPECT_EQ(r.grains.size(), kBalls.size()) << "variant " << variant;
    EXPECT_GE(matched_share(truth, r.labels), 1.0) << "variant " << variant;
  }
}

TEST(SegmentGrains, Uint16InputAndEdgeGrainRemoval) {
  // The 3^3 lattice (centres 9, 22, 35 +- 0.8, radius 7) in a volume that ends at 35: the spheres of
  // the last layer along any axis are cut by a face, the 2 x 2 x 2 others are clear.
  const Volume<float> f = test::scan_balls({36, 36, 36}, kBalls, 7, 0.03);
  Volume<std::uint16_t> grey(f.shape(), f.voxel_size());
  for (std::size_t i = 0; i < f.size(); ++i) grey.values()[i] = static_cast<std::uint16_t>(std::lround(f.values()[i] * 4000.0));
  SegmentOptions o;
  o.region_mode = RegionMode::whole_volume;
  o.expected_d50_m = 14e-5;
  o.remove_edge_grains = true;
  const SegmentResult r = segment_grains(grey, o);
  EXPECT_EQ(r.grains.size(), 8u);
  EXPECT_EQ(r.edge_grains_removed, 19u);
  for (const GrainRecord& g : r.grains) EXPECT_FALSE(g.touches_edge);
}

TEST(SegmentGrains, GivenCylinderBoundsTheVoidRatio) {
  const Volume<float> grey = test::scan_balls(kShape, kBalls, 8, 0.03);
  SegmentOptions o;
  o.region_mode = RegionMode::given_cylinder;
  o.region.centre_x = o.region.centre_y = 22e-5;
  o.region.radius = 10e-5;
  const SegmentResult r = segment_grains(grey, o);
  EXPECT_DOUBLE_EQ(r.region.radius, 10e-5);
  EXPECT_GT(r.void_ratio.solid_m3 + r.void_ratio.void_m3, 0.0);
  // pi r^2 h of voxel centres: about 314 voxels per slice over 44 slices.
  EXPECT_NEAR((r.void_ratio.solid_m3 + r.void_ratio.void_m3) / 1e-15, 44 * 3.14159 * 100, 44 * 12.0);
}

TEST(SegmentGrains, AMembraneRimStaysVoidAtTheDefaults) {
  // A triaxial scan in miniature: 27 spheres 8 voxels across inside a thick membrane shell (radius
  // 17.5 to 25 voxels, grey 0.4 between void 0.25 and grain 0.75) with air in the corners. Over the
  // whole volume the air and the membrane pull Otsu's threshold below the membrane's grey: the
  // membrane would become solid and weld the sample together.
  std::vector<Ball> balls;
  for (Ball b : test::jittered_lattice(3, 4.0, 9.0, 9.0, 0.3, 0.05, 5)) balls.push_back({b.z, b.y + 7.5, b.x + 7.5, b.r});
  const Shape3 shape{36, 52, 52};
  Volume<float> grey = test::scan_balls(shape, balls, 9, 0.0);
  for (std::size_t z = 0; z < shape[0]; ++z)
    for (std::size_t y = 0; y < shape[1]; ++y)
      for (std::size_t x = 0; x < shape[2]; ++x) {
        const double r = std::hypot(y - 25.5, x - 25.5);
        if (r >= 17.5 && r <= 25.0) grey(z, y, x) = 0.4f;
      }
  std::mt19937 rng(10);
  std::normal_distribution<float> noise(0.0f, 0.03f);
  for (float& v : grey.values()) v += noise(rng);
  ASSERT_LT(otsu_threshold(grey), 0.4);  // the failure that Otsu inside the sample cylinder avoids

  const SegmentResult r = segment_grains(grey, SegmentOptions{});
  EXPECT_GT(r.threshold, 0.43);
  EXPECT_LT(r.region.radius, 18e-5);  // the cylinder stops inside the membrane
  EXPECT_EQ(r.grains.size(), balls.size());
  EXPECT_DOUBLE_EQ(matched_share(test::label_balls(shape, balls), r.labels), 1.0);
}

TEST(SegmentGrains, RefusesVolumesThatCannotBeSegmented) {
  SegmentOptions o;
  EXPECT_NE(message_of([&] { segment_grains(Volume<std::uint16_t>(), o); }).find("empty"), std::string::npos);
  EXPECT_NE(message_of([&] { segment_grains(constant<std::uint16_t>(700), o); }).find("constant"), std::string::npos);
  Volume<float> nan = constant<float>(1.0f);
  nan(3, 3, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(message_of([&] { segment_grains(nan, o); }).find("NaN"), std::string::npos);
  SegmentOptions fixed;
  fixed.threshold = 100.0;
  EXPECT_NE(message_of([&] { segment_grains(constant<std::uint16_t>(700), fixed); }).find("every voxel is solid"),
            std::string::npos);
  fixed.threshold = 1000.0;
  EXPECT_NE(message_of([&] { segment_grains(constant<std::uint16_t>(700), fixed); }).find("no solid"), std::string::npos);
  // Grains of one voxel: isolated specks are fragments, and nothing is left.
  Volume<std::uint8_t> specks({12, 12, 12}, {1e-5, 1e-5, 1e-5});
  for (std::size_t z = 2; z < 12; z += 4)
    for (std::size_t y = 2; y < 12; y += 4)
      for (std::size_t x = 2; x < 12; x += 4) specks(z, y, x) = 200;
  SegmentOptions plain;
  plain.denoise = Denoise::none;
  plain.region_mode = RegionMode::whole_volume;
  EXPECT_NE(message_of([&] { segment_grains(specks, plain); }).find("no grain is left"), std::string::npos);
}

TEST(SegmentGrains, ValidatesOptionsBeforeWork) {
  SegmentOptions o;
  o.h_vox = -1.0;
  EXPECT_THROW(segment::validate(o), UsageError);
  o = {};
  o.denoise = Denoise::gaussian;
  o.gaussian_sigma_vox = 0.0;
  EXPECT_THROW(segment::validate(o), UsageError);
  o = {};
  o.region_mode = RegionMode::given_cylinder;
  EXPECT_THROW(segment::validate(o), UsageError);
  o = {};
  o.min_distance_vox = 0.0;
  EXPECT_THROW(segment::validate(o), UsageError);
}

TEST(LabelsFile, RoundTripsEveryField) {
  test::TempDir dir;
  const Volume<float> grey = test::scan_balls(kShape, kBalls, 9, 0.03);
  SegmentResult r = segment_grains(grey, SegmentOptions{});
  LabelsFile c{r.labels, r.grains, {r.region, r.void_ratio}, R"({"h_vox": 0.7})"};
  c.sample.region.z_min = -1.5e-3;                                  // a bounded end
  c.sample.region.z_max = std::numeric_limits<double>::infinity();  // and an open one
  write_labels_file(dir / "l.h5", c, {"line one"});
  const LabelsFile back = read_labels_file(dir / "l.h5");
  EXPECT_EQ(back.labels.values(), c.labels.values());
  EXPECT_EQ(back.labels.voxel_size(), c.labels.voxel_size());
  ASSERT_EQ(back.grains.size(), c.grains.size());
  for (std::size_t i = 0; i < c.grains.size(); ++i) {
    EXPECT_EQ(back.grains[i].label, c.grains[i].label);
    EXPECT_EQ(back.grains[i].voxels, c.grains[i].voxels);
    EXPECT_EQ(back.grains[i].bbox, c.grains[i].bbox);
    EXPECT_EQ(back.grains[i].centroid_xyz, c.grains[i].centroid_xyz);
    EXPECT_EQ(back.grains[i].touches_edge, c.grains[i].touches_edge);
  }
  EXPECT_DOUBLE_EQ(back.sample.void_ratio.e, c.sample.void_ratio.e);
  EXPECT_DOUBLE_EQ(read_void_ratio(dir / "l.h5"), c.sample.void_ratio.e);  // without the label image
  EXPECT_DOUBLE_EQ(back.sample.region.radius, c.sample.region.radius);
  EXPECT_DOUBLE_EQ(back.sample.region.z_min, -1.5e-3);
  EXPECT_TRUE(std::isinf(back.sample.region.z_max));  // an unbounded extent survives the NaN encoding
  EXPECT_EQ(back.parameters_json, c.parameters_json);
}

TEST(Preview, TintsGrainsAndDrawsOutlines) {
  // 1 row x 4 pixels: void, grain 1, grain 1, grain 2.
  const RgbImage im = overlay_labels({0.f, 1.f, 1.f, 1.f}, {0, 1, 1, 2}, 1, 4, 0.0, 1.0);
  ASSERT_EQ(im.rgb.size(), 12u);
  EXPECT_EQ(im.rgb[0], 255);  // the void pixel left of a grain is the white outline
  EXPECT_EQ(im.rgb[1], 255);
  // Pixel 1 (inside grain 1) is a 40 % tint of white: no channel below 0.6 * 255.
  for (int k = 3; k < 6; ++k) EXPECT_GE(im.rgb[k], 153);
  // Pixel 2 borders grain 2: drawn fully in grain 1's colour, which differs from pixel 1's tint.
  EXPECT_NE(std::vector<std::uint8_t>(im.rgb.begin() + 3, im.rgb.begin() + 6),
            std::vector<std::uint8_t>(im.rgb.begin() + 6, im.rgb.begin() + 9));
  const RgbImage two = side_by_side({im, overlay_labels({0.f, 0.f}, {0, 0}, 2, 1, 0.0, 1.0)}, 3);
  EXPECT_EQ(two.width, 4u + 3u + 1u);
  EXPECT_EQ(two.height, 2u);
  EXPECT_THROW(overlay_labels({0.f}, {0, 0}, 1, 2, 0.0, 1.0), UsageError);
}
