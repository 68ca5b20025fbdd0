// The golden-number API (support/golden.hpp): a check passes within its tolerance and fails outside
// it with every figure named; regeneration rewrites measured references (and fails saying so),
// never published ones; the switch is read from the environment; the files in tests/data are sound
// and in the writer's form, so that a regeneration's diff shows only the numbers that changed.
#include "support/golden.hpp"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "support/run_tool.hpp"

using namespace graintwin;
using test::Golden;
using test::NewReference;
using test::Tolerance;

namespace {

// Two references: one measured by our code, one from the literature.
const std::string kSuite = R"({
  "peak_force_over_hertz": {
    "value": 1.0393,
    "relative": 0.001,
    "source": "measured",
    "note": "peak force over Hertz's, tet10 graded mesh"
  },
  "hertz_max_approach_m": {
    "value": 0.000274,
    "absolute": 5e-07,
    "source": "published",
    "note": "Chung & Ooi test 1, Hertz's maximum approach"
  }
}
)";

std::string read(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::filesystem::path write_suite(const test::TempDir& dir, const std::string& text = kSuite) {
  std::ofstream(dir / "suite.json") << text;
  return dir / "suite.json";
}

/// The messages of the gtest failures `f` reports (caught, so they do not fail this test).
std::vector<std::string> failures_of(const std::function<void()>& f) {
  ::testing::TestPartResultArray results;
  {
    ::testing::ScopedFakeTestPartResultReporter catcher(::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &results);
    f();
  }
  std::vector<std::string> messages;
  for (int i = 0; i < results.size(); ++i) messages.push_back(results.GetTestPartResult(i).message());
  return messages;
}

double stored(const std::filesystem::path& file, const std::string& name) {
  return nlohmann::json::parse(read(file))[name]["value"].get<double>();
}

/// Sets an environment variable for the scope, then restores it.
class ScopedEnvironment {
 public:
  ScopedEnvironment(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) ::setenv(name, value, 1); else ::unsetenv(name);
  }
  ~ScopedEnvironment() {
    if (old_) ::setenv(name_, old_->c_str(), 1); else ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

}  // namespace

TEST(Golden, ToleranceIsTheLargerOfAbsoluteAndRelative) {
  EXPECT_DOUBLE_EQ((Tolerance{0.01, 0.001}.allowed(100.0)), 0.1);
  EXPECT_DOUBLE_EQ((Tolerance{0.01, 0.001}.allowed(-1.0)), 0.01);
  EXPECT_DOUBLE_EQ((Tolerance{0.0, 0.05}.allowed(-2.0)), 0.1);
}

TEST(Golden, PassesWithinTheToleranceAndFailsOutsideNamingEveryFigure) {
  test::TempDir dir;
  Golden g(write_suite(dir), Golden::Mode::check);
  EXPECT_TRUE(failures_of([&] { EXPECT_TRUE(g.check("peak_force_over_hertz", 1.0402)); }).empty());  // 0.9e-3 off
  EXPECT_TRUE(failures_of([&] { EXPECT_TRUE(g.check("hertz_max_approach_m", 274.4e-6)); }).empty());

  const auto off = failures_of([&] { EXPECT_FALSE(g.check("peak_force_over_hertz", 1.0405)); });  // 1.2e-3 off
  ASSERT_EQ(off.size(), 1u);
  for (const std::string& says : {std::string("peak_force_over_hertz"), std::string("1.0405 measured"), std::string("1.0393 expected"),
                                  std::string("tolerance 0.0010393"), std::string("relative 0.001"), std::string("tet10 graded mesh"),
                                  (dir / "suite.json").string(), std::string("GRAINTWIN_REGENERATE_GOLDEN=1")})
    EXPECT_NE(off[0].find(says), std::string::npos) << says << " not in: " << off[0];
  // A published figure is not ours to regenerate: the message does not offer it.
  const auto published = failures_of([&] { g.check("hertz_max_approach_m", 275e-6); });
  ASSERT_EQ(published.size(), 1u);
  EXPECT_NE(published[0].find("absolute 5e-07"), std::string::npos) << published[0];
  EXPECT_EQ(published[0].find("REGENERATE"), std::string::npos) << published[0];
  // NaN never passes; a check never writes in check mode.
  EXPECT_EQ(failures_of([&] { g.check("peak_force_over_hertz", std::nan("")); }).size(), 1u);
  EXPECT_EQ(read(dir / "suite.json"), kSuite);
}

TEST(Golden, MissingReferencesFilesAndDamagedFilesFail) {
  test::TempDir dir;
  Golden g(write_suite(dir), Golden::Mode::check);
  const auto missing = failures_of([&] { g.check("contact_time_over_hertz", 1.0); });
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_NE(missing[0].find("no reference of this name"), std::string::npos) << missing[0];
  EXPECT_EQ(failures_of([&] { Golden(dir / "none.json", Golden::Mode::check).check("x", 1.0); }).size(), 1u);
  // A tolerance in the call that differs from the file's: one of them is wrong.
  const auto twice = failures_of([&] { g.check("peak_force_over_hertz", 1.0393, NewReference{{0, 0.01}, "a note"}); });
  ASSERT_EQ(twice.size(), 1u);
  EXPECT_NE(twice[0].find("keep one"), std::string::npos) << twice[0];
  EXPECT_TRUE(failures_of([&] { g.check("peak_force_over_hertz", 1.0393, NewReference{{0, 0.001}, "a note"}); }).empty());
  // Damaged files are refused whole, in either mode, and never rewritten.
  for (const std::string& bad : {std::string("{ \"x\": { \"value\": 1 "),
                                 std::string(R"({"x": {"value": 1, "relativ": 0.1, "source": "measured", "note": "n"}})"),
                                 std::string(R"({"x": {"value": 1, "relative": -0.1, "source": "measured", "note": "n"}})"),
                                 std::string(R"({"x": {"value": 1, "relative": 0.1, "source": "guessed", "note": "n"}})"),
                                 std::string(R"({"x": {"value": 1, "relative": 0.1, "source": "measured"}})")}) {
    write_suite(dir, bad);
    EXPECT_FALSE(test::golden_file_problems(bad).empty()) << bad;
    for (Golden::Mode mode : {Golden::Mode::check, Golden::Mode::regenerate}) {
      const auto damaged = failures_of([&] { Golden(dir / "suite.json", mode).check("x", 2.0, NewReference{{0, 0.1}, "n"}); });
      ASSERT_EQ(damaged.size(), 1u) << bad;
      EXPECT_NE(damaged[0].find("damaged"), std::string::npos) << damaged[0];
      EXPECT_EQ(read(dir / "suite.json"), bad);
    }
  }
}

TEST(Golden, RegenerationRewritesMeasuredReferencesOnlyAndFailsSayingWhat) {
  test::TempDir dir;
  const auto file = write_suite(dir);
  Golden g(file, Golden::Mode::regenerate);
  // The stored value measured again: nothing to write, the check passes.
  EXPECT_TRUE(failures_of([&] { EXPECT_TRUE(g.check("peak_force_over_hertz", 1.0393)); }).empty());
  EXPECT_EQ(read(file), kSuite);
  // A new measurement is written to the digits that resolve a thousandth of the tolerance (1e-6
  // here: 7 significant digits), keeping the tolerance and note, and the run fails naming the change.
  const auto rewrote = failures_of([&] { g.check("peak_force_over_hertz", 1.071234567); });
  ASSERT_EQ(rewrote.size(), 1u);
  EXPECT_NE(rewrote[0].find("regenerated: 1.071235 (was 1.0393"), std::string::npos) << rewrote[0];
  const auto written = nlohmann::json::parse(read(file));
  EXPECT_EQ(written["peak_force_over_hertz"]["value"].get<double>(), 1.071235);
  EXPECT_EQ(written["peak_force_over_hertz"]["relative"].get<double>(), 0.001);
  EXPECT_EQ(written["peak_force_over_hertz"]["note"], "peak force over Hertz's, tet10 graded mesh");
  EXPECT_EQ(read(file), test::canonical_golden_text(read(file)));
  // Checked again without the switch, the new value passes.
  EXPECT_TRUE(failures_of([&] { Golden(file, Golden::Mode::check).check("peak_force_over_hertz", 1.0712345); }).empty());
  // A published figure is checked, not rewritten.
  EXPECT_EQ(failures_of([&] { g.check("hertz_max_approach_m", 280e-6); }).size(), 1u);
  EXPECT_EQ(stored(file, "hertz_max_approach_m"), 274e-6);
  // A new reference needs a tolerance and a note from the test; with them it is created.
  EXPECT_EQ(failures_of([&] { g.check("restitution", 0.8); }).size(), 1u);
  const auto created = failures_of([&] { g.check("restitution", 0.81234, NewReference{{1e-4, 0}, "restitution of the box"}); });
  ASSERT_EQ(created.size(), 1u);
  EXPECT_NE(created[0].find("created with value 0.81234"), std::string::npos) << created[0];
  const auto entry = nlohmann::json::parse(read(file))["restitution"];
  EXPECT_EQ(entry["absolute"].get<double>(), 1e-4);
  EXPECT_FALSE(entry.contains("relative"));
  EXPECT_EQ(entry["source"], "measured");
  EXPECT_TRUE(test::golden_file_problems(read(file)).empty()) << test::golden_file_problems(read(file));
  // A missing file is created by regeneration.
  EXPECT_EQ(failures_of([&] { Golden(dir / "sub" / "new.json", Golden::Mode::regenerate).check("x", 2.5, NewReference{{0, 0.01}, "n"}); }).size(), 1u);
  EXPECT_EQ(stored(dir / "sub" / "new.json", "x"), 2.5);
}

TEST(Golden, TheEnvironmentSwitchesRegenerationOn) {
  {
    ScopedEnvironment off(test::kRegenerateGolden, nullptr);
    EXPECT_EQ(Golden("any_suite").mode(), Golden::Mode::check);
    EXPECT_EQ(Golden("any_suite").file(), std::filesystem::path(GRAINTWIN_TEST_DATA) / "any_suite.json");
  }
  {
    ScopedEnvironment on(test::kRegenerateGolden, "1");
    EXPECT_EQ(Golden("any_suite").mode(), Golden::Mode::regenerate);
  }
  {
    ScopedEnvironment unclear(test::kRegenerateGolden, "yes");
    EXPECT_THROW(Golden("any_suite"), std::runtime_error);
  }
}

TEST(Golden, EveryDataFileIsSoundAndInTheWritersForm) {
  std::size_t files = 0;
  for (const auto& f : std::filesystem::directory_iterator(GRAINTWIN_TEST_DATA)) {
    if (f.path().extension() != ".json") continue;
    ++files;
    const std::string text = read(f.path());
    EXPECT_EQ(test::golden_file_problems(text), "") << f.path();
    EXPECT_EQ(text, test::canonical_golden_text(text)) << f.path() << ": rewrite it in the form the regeneration writes";
  }
  EXPECT_GT(files, 0u);
}
