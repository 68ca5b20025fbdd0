// io/series_record: the scans' applied axial strains of a series.json as ctsynth writes it, and a
// file that is not one refused in one sentence naming it and the fix.
#include <gtest/gtest.h>

#include "graintwin/core/error.hpp"
#include "graintwin/io/series_record.hpp"
#include "support/run_tool.hpp"
#include "support/scene_text.hpp"

using namespace graintwin;
using test::write_text;

namespace {
std::string error_of(const std::filesystem::path& path) {
  try {
    io::read_series_axial_strains(path);
  } catch (const UsageError& e) {
    return e.message();
  }
  return "no error";
}
}  // namespace

TEST(IoSeriesRecord, TheScansStrainsComeInScanOrder) {
  test::TempDir dir;
  const auto path = write_text(dir, "series.json",
                               R"({"scans": [{"scan": "scan_000", "axial_strain": 0}, {"scan": "scan_001", "axial_strain": 0.05}],
                                   "loading": "simulated"})");
  EXPECT_EQ(io::read_series_axial_strains(path), (std::vector<double>{0.0, 0.05}));
}

TEST(IoSeriesRecord, WhatIsNotARecordIsRefusedNamingTheFileAndTheFix) {
  test::TempDir dir;
  EXPECT_NE(error_of(dir / "none.json").find("cannot read"), std::string::npos);
  const std::string not_json = error_of(write_text(dir, "a.json", "{not json"));
  EXPECT_NE(not_json.find("a.json is not a JSON object with a \"scans\" array; pass a series.json"), std::string::npos) << not_json;
  EXPECT_NE(error_of(write_text(dir, "b.json", "[1, 2]")).find("is not a JSON object"), std::string::npos);
  const std::string no_strain = error_of(write_text(dir, "c.json", R"({"scans": [{"scan": "scan_000"}]})"));
  EXPECT_NE(no_strain.find("c.json: every entry of \"scans\" needs a number \"axial_strain\""), std::string::npos) << no_strain;
}
