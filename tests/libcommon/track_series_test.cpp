// shapes2tracks' stage as a library call (track/series): the parameters it records and the
// rotation method names, and the whole stage on two synthetic scans written as shapes files; the
// grains a tracks table follows through the whole series.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>

#include "graintwin/core/error.hpp"
#include "graintwin/track/series.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::track;

TEST(TrackSeries, ParametersRecordTheMatcherAndRotationOptions) {
  ChainOptions co;
  RotationOptions ro;
  co.match.method = Method::paper;
  co.max_gap = 2;
  ro.method = RotationMethod::axes;
  ro.degree = 6;
  nlohmann::json p = nlohmann::json::parse(tracks_parameters_json(co, ro));
  EXPECT_EQ(p["method"], "paper");
  EXPECT_EQ(p["max_gap"], 2);
  EXPECT_EQ(p["rotation"], "axes");
  EXPECT_EQ(p["rotation_degree"], 6);
  EXPECT_EQ(p["volume_tol"], 0.10);  // the paper's filter
  EXPECT_FALSE(p.contains("lost_cost"));  // the improved matcher's own settings only for it
  co.match.method = Method::improved;
  co.match.lost_cost = 50.0;
  p = nlohmann::json::parse(tracks_parameters_json(co, ro));
  EXPECT_EQ(p["lost_cost"], 50.0);
  EXPECT_EQ(p["passes"], co.match.passes);
  EXPECT_LT(p["volume_tol"].get<double>(), 0.0);  // improved weighs the volume change instead of filtering
}

TEST(TrackSeries, RotationMethodNamesAreTheOnesTheParserReads) {
  for (RotationMethod m : {RotationMethod::none, RotationMethod::axes, RotationMethod::sh})
    EXPECT_EQ(parse_rotation_method(rotation_method_name(m)), m);
}

TEST(TrackSeries, AMissingOrEmptyScanIsNamed) {
  test::TempDir dir;
  try {
    track_series({dir / "absent.h5", dir / "absent2.h5"}, {}, {});
    ADD_FAILURE() << "a missing file was read";
  } catch (const Error& e) {
    std::string text = e.message();
    for (const std::string& line : e.context()) text += "\n" + line;
    EXPECT_NE(text.find("absent.h5"), std::string::npos) << text;
  }
}

TEST(TracksFile, GrainsTrackedThroughoutAreThoseOfTheFirstScanStillThereInTheLast) {
  TracksTable t;
  t.tracks = 4, t.scans = 3;
  // Track 0 runs through, 1 is lost after the first scan, 2 is lost in the middle and found again,
  // 3 starts in the second scan.
  t.label = {5, 6, 7,  //
             9, 0, 0,  //
             2, 0, 4,  //
             0, 3, 8};
  EXPECT_EQ(labels_tracked_throughout(t), (std::set<std::uint32_t>{2, 5}));
  EXPECT_TRUE(labels_tracked_throughout(TracksTable{}).empty());
}
