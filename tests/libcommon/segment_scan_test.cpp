// ct2labels' stage (segment/segment_scan): the option names and their parsing, a scan file
// segmented into a labels file's content with the parameters it records, the refusals before and
// after reading, and the preview picture.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/segment_scan.hpp"
#include "support/phantoms.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::segment;

namespace {

// Eight spheres of radius 6-8 voxels, apart from each other, in 40^3 voxels of 20 um.
const std::vector<test::Ball> kBalls = test::jittered_lattice(2, 7.0, 18.0, 11.0, 0.5, 0.1, 3);

std::filesystem::path write_scan(const test::TempDir& dir) {
  const Volume<float> f = test::scan_balls({40, 40, 40}, kBalls, 2, 0.02, {2e-5, 2e-5, 2e-5});
  const Volume<std::uint16_t> v = test::uint16_scan(f);
  io::write_volume_file(dir / "scan.h5", v, {"phantom scan"});
  return dir / "scan.h5";
}

}  // namespace

TEST(SegmentScan, OptionNamesParseBackAndUnknownOnesAreRefused) {
  for (Denoise d : {Denoise::none, Denoise::median, Denoise::gaussian}) EXPECT_EQ(parse_denoise(to_string(d)), d);
  for (MarkerMethod m : {MarkerMethod::h_maxima, MarkerMethod::peaks}) EXPECT_EQ(parse_marker_method(to_string(m)), m);
  for (FragmentPolicy f : {FragmentPolicy::merge, FragmentPolicy::remove}) EXPECT_EQ(parse_fragment_policy(to_string(f)), f);
  for (RegionMode r : {RegionMode::auto_cylinder, RegionMode::given_cylinder, RegionMode::whole_volume})
    EXPECT_EQ(parse_region_mode(to_string(r)), r);
  EXPECT_STREQ(to_string(MarkerMethod::h_maxima), "h-maxima");
  EXPECT_STREQ(to_string(RegionMode::whole_volume), "volume");
  const auto refused = [](auto parse, const std::string& text, const std::string& message) {
    try {
      parse(text);
      ADD_FAILURE() << text << " was accepted";
    } catch (const UsageError& e) {
      EXPECT_EQ(e.message(), message);
    }
  };
  refused(parse_denoise, "blur", "--denoise 'blur' is not none, median or gaussian");
  refused(parse_marker_method, "h_maxima", "--markers 'h_maxima' is not h-maxima or peaks");
  refused(parse_fragment_policy, "keep", "--fragments 'keep' is not merge or remove");
  refused(parse_region_mode, "box", "--region 'box' is not auto, volume or cylinder");
}

TEST(SegmentScan, AScanBecomesTheLabelsFileContent) {
  test::TempDir dir;
  const io::H5File scan = io::H5File::open(write_scan(dir));
  SegmentOptions o;
  o.region_mode = RegionMode::whole_volume;
  std::vector<std::string> steps;
  double last = 0.0;
  const ScanSegmentation s = segment_scan(scan, o, [&](const std::string& step) {
    steps.push_back(step);
    return std::function<void(double)>([&](double fraction) { last = fraction; });
  });
  EXPECT_EQ(steps, std::vector<std::string>{"segment"});
  EXPECT_DOUBLE_EQ(last, 1.0);
  EXPECT_EQ(s.labels.grains.size(), kBalls.size());
  EXPECT_EQ(s.labels.labels.shape(), (Shape3{40, 40, 40}));
  EXPECT_FALSE(std::isfinite(s.labels.sample.region.radius));  // the whole volume
  const nlohmann::json p = nlohmann::json::parse(s.labels.parameters_json);
  EXPECT_EQ(p["denoise"], "gaussian");
  EXPECT_EQ(p["markers"], "h-maxima");
  EXPECT_EQ(p["fragments"], "merge");
  EXPECT_EQ(p["region"], "volume");
  EXPECT_EQ(p["grains"], kBalls.size());
  EXPECT_EQ(p["threshold"], s.threshold);
  EXPECT_EQ(p["threshold_method"], "otsu");
  // Otsu between the void (1000) and grain (3000) grey levels.
  EXPECT_GT(s.threshold, 1500.0);
  EXPECT_LT(s.threshold, 2500.0);

  write_segmentation_preview(dir / "p.png", scan, s.labels.labels, s.threshold);
  EXPECT_GT(std::filesystem::file_size(dir / "p.png"), 0u);
}

TEST(SegmentScan, KernelsWiderThanTheScanAndLabelImagesAreRefused) {
  test::TempDir dir;
  SegmentOptions wide;
  wide.gaussian_sigma_vox = 20.0;  // a 61-voxel kernel on 40 voxels
  bool made_progress = false;
  const auto progress = [&](const std::string&) {
    made_progress = true;
    return std::function<void(double)>();
  };
  EXPECT_THROW(segment_scan(io::H5File::open(write_scan(dir)), wide, progress), UsageError);
  EXPECT_FALSE(made_progress);  // refused before the scan is read

  io::write_volume_file(dir / "labels.h5", test::label_balls({40, 40, 40}, kBalls), {"labels"});
  try {
    segment_scan(io::H5File::open(dir / "labels.h5"), SegmentOptions{});
    FAIL() << "a label image was segmented";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("labels.h5 is uint32"), std::string::npos) << e.message();
  }
}
