// shapes2tracks' stage as a library call (track/series): the parameters it records and the
// rotation method names, and the whole stage on two synthetic scans written as shapes files.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "graintwin/core/error.hpp"
#include "graintwin/track/series.hpp"
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
