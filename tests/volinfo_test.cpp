// volinfo: CLI contract, text and JSON reports, bad inputs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <limits>

#include "graintwin/io/volume_io.hpp"
#include "support/cli_contract.hpp"
#include "support/fixtures.hpp"

using namespace graintwin;
using test::run_tool;

TEST(Volinfo, StandardCli) { test::expect_standard_cli("volinfo"); }

TEST(Volinfo, JsonDescribesGeometryRangeAndHistory) {
  test::TempDir dir;
  auto v = test::ramp_volume<float>({4, 5, 6}, {3e-5, 2e-5, 1e-5});
  v(1, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  io::write_volume_file(dir / "v.h5", v, {"made by a test"});
  const auto r = run_tool("volinfo", {(dir / "v.h5").string(), "--json", "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "volume");
  EXPECT_EQ(j["schema_version"], 1);
  ASSERT_EQ(j["images"].size(), 1u);
  EXPECT_EQ(j["images"][0]["shape_zyx"], nlohmann::json({4, 5, 6}));
  EXPECT_EQ(j["images"][0]["dtype"], "float32");
  EXPECT_DOUBLE_EQ(j["images"][0]["voxel_size_m_zyx"][0].get<double>(), 3e-5);
  EXPECT_EQ(j["images"][0]["non_finite"], 1);
  EXPECT_DOUBLE_EQ(j["images"][0]["min"].get<double>(), -20.0);
  EXPECT_EQ(j["history"], nlohmann::json({"made by a test"}));
}

TEST(Volinfo, TextReportForPeople) {
  test::TempDir dir;
  io::write_volume_file(dir / "v.h5", test::ramp_volume<std::uint16_t>({2, 3, 4}), {"line"});
  const auto r = run_tool("volinfo", {(dir / "v.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("kind:            volume"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 x 3 x 4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("history:\n  line"), std::string::npos) << r.out;
}

TEST(Volinfo, RejectsNonGrainTwinFiles) {
  test::TempDir dir;
  std::ofstream(dir / "fake.h5") << "not hdf5";
  auto r = run_tool("volinfo", {(dir / "fake.h5").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("not an HDF5 file"), std::string::npos);
  { io::H5File f = io::H5File::create(dir / "bare.h5"); }
  r = run_tool("volinfo", {(dir / "bare.h5").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("kind"), std::string::npos);
  r = run_tool("volinfo", {(dir / "missing.h5").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.h5"), std::string::npos);
}

TEST(Volinfo, ReadsOptionsFromATomlConfig) {
  test::TempDir dir;
  io::write_volume_file(dir / "v.h5", test::ramp_volume<std::uint8_t>({2, 3, 4}), {});
  std::ofstream(dir / "volinfo.toml") << "json = true\nquiet = true\n";
  const auto r = run_tool("volinfo", {(dir / "v.h5").string(), "--config", (dir / "volinfo.toml").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["kind"], "volume");
  EXPECT_TRUE(r.err.empty()) << r.err;
}

TEST(Volinfo, AThousandThreadsGiveTheSameReport) {
  // Far more threads than processors, as the --threads cap allows: no crash, the same numbers.
  test::TempDir dir;
  io::write_volume_file(dir / "v.h5", test::ramp_volume<std::uint16_t>({20, 21, 22}), {"ramp"});
  const auto one = run_tool("volinfo", {(dir / "v.h5").string(), "--json", "-q", "-j", "1"});
  const auto many = run_tool("volinfo", {(dir / "v.h5").string(), "--json", "-q", "-j", "1024"});
  ASSERT_EQ(many.exit_code, 0) << many.err;
  EXPECT_EQ(many.out, one.out);
}
