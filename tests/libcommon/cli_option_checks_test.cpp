// The option contract's CLI11 checks: finite numbers in a stated range, whole numbers, lengths with
// units; ranges and refused values printed readably, the range shown in --help.
#include <gtest/gtest.h>

#include <limits>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/core/error.hpp"

using namespace graintwin;

namespace {

/// Parses `--x VALUE` through an option with `check`; the validation message, empty when accepted.
template <class T>
std::string refusal(const CLI::Validator& check, const std::string& value, T* parsed = nullptr) {
  CLI::App app("test");
  T target{};
  app.add_option("--x", target, "an option")->check(check);
  try {
    app.parse(std::vector<std::string>{value, "--x"});  // CLI11 takes the arguments reversed
  } catch (const CLI::ParseError& e) {
    return e.what();
  }
  if (parsed) *parsed = target;
  return {};
}

}  // namespace

TEST(NumberRange, ClosedAndHalfOpenIntervalsNeverContainNanOrInfinity) {
  const cli::NumberRange r = cli::closed(0, 20, "voxels");
  EXPECT_TRUE(r.contains(0.0));
  EXPECT_TRUE(r.contains(20.0));
  EXPECT_FALSE(r.contains(20.000001));
  EXPECT_FALSE(r.contains(-1e-300));
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (double v : {nan, inf, -inf}) EXPECT_FALSE(r.contains(v)) << v;
  const cli::NumberRange positive = cli::above(0, 1);
  EXPECT_FALSE(positive.contains(0.0));
  EXPECT_TRUE(positive.contains(1e-300));
  EXPECT_TRUE(positive.contains(1.0));
  EXPECT_FALSE(cli::closed(-inf, inf).contains(inf)) << "even an unbounded range wants a finite number";
}

TEST(NumberRange, PrintsRangesReadably) {
  EXPECT_EQ(cli::closed(0, 20, "voxels").text(), "[0, 20] voxels");
  EXPECT_EQ(cli::above(0, 1e6, "d50").text(), "(0, 1e+06] d50");
  EXPECT_EQ(cli::closed(0.5, 0.74).text(), "[0.5, 0.74]");
  EXPECT_EQ(cli::format_number(std::numeric_limits<double>::max()), "1.79769e+308");
  EXPECT_EQ(cli::format_length(27.5e-6), "27.5 um");
  EXPECT_EQ(cli::format_length(3e-3), "3 mm");
  EXPECT_EQ(cli::format_length(1.0), "1 m");
  EXPECT_EQ(cli::format_length(-1.5e-3), "-1.5 mm");
  EXPECT_EQ(cli::format_length(50e-9), "50 nm");
}

TEST(NumberIn, RefusesNanInfinitiesAndValuesOutsideWithTheRangeAndTheValue) {
  const CLI::Validator blur = cli::number_in(cli::closed(0, 20, "voxels"));
  double v = -1;
  EXPECT_EQ(refusal<double>(blur, "0.8", &v), "");
  EXPECT_EQ(v, 0.8);
  EXPECT_EQ(refusal<double>(blur, "20"), "");
  EXPECT_EQ(refusal<double>(blur, "0"), "");
  EXPECT_EQ(refusal<double>(blur, "nan"), "--x: must be a finite number in [0, 20] voxels, not nan");
  for (const char* bad : {"NaN", "inf", "-inf", "infinity", "1e6", "-0.1", "20.5", "1e400", "abc", ""})
    EXPECT_NE(refusal<double>(blur, bad).find("must be a finite number in [0, 20] voxels"), std::string::npos) << bad;
  const std::string long_number(400, '9');
  const std::string m = refusal<double>(blur, long_number);
  EXPECT_LT(m.size(), 120u) << "a pasted huge number must not flood the message: " << m;
}

TEST(NumberIn, OpenLowerBoundRefusesZero) {
  const CLI::Validator positive = cli::number_in(cli::above(0, 100, "d50"));
  EXPECT_EQ(refusal<double>(positive, "1e-9"), "");
  EXPECT_EQ(refusal<double>(positive, "0"), "--x: must be a finite number in (0, 100] d50, not 0");
}

TEST(NumberIn, ChecksOptionalsAndEveryElementOfAList) {
  const CLI::Validator fraction = cli::number_in(cli::closed(0, 1));
  std::optional<double> opt;
  EXPECT_NE(refusal<std::optional<double>>(fraction, "nan").find("not nan"), std::string::npos);
  EXPECT_EQ(refusal<std::optional<double>>(fraction, "0.5", &opt), "");
  EXPECT_EQ(opt.value_or(-1), 0.5);
  CLI::App app("test");
  std::vector<double> list;
  app.add_option("--strains", list, "")->delimiter(',')->check(fraction);
  EXPECT_THROW(app.parse(std::vector<std::string>{"0,0.5,nan", "--strains"}), CLI::ValidationError);
}

TEST(WholeNumberIn, RefusesFractionsNegativesForUnsignedAndNan) {
  const CLI::Validator count = cli::whole_number_in(0, 1000000, "directions");
  int n = -1;
  EXPECT_EQ(refusal<int>(count, "512", &n), "");
  EXPECT_EQ(n, 512);
  EXPECT_EQ(refusal<int>(count, "0"), "");
  EXPECT_EQ(refusal<int>(count, "1000000000"), "--x: must be a whole number in [0, 1000000] directions, not 1000000000");
  for (const char* bad : {"-1", "2.5", "nan", "inf", "1e12", "x"})
    EXPECT_NE(refusal<int>(count, bad).find("must be a whole number in [0, 1000000] directions"), std::string::npos) << bad;
  std::size_t u = 0;
  EXPECT_NE(refusal<std::size_t>(cli::whole_number_in(0, 100), "-1", &u).find("[0, 100]"), std::string::npos)
      << "CLI11 alone would read -1 into an unsigned option as 2^64 - 1";
  EXPECT_EQ(refusal<int>(count, "0x10", &n), "");
  EXPECT_EQ(n, 16) << "the validator reads integers as CLI11 does";
}

TEST(LengthIn, ChecksLengthsWithUnitsAgainstAPhysicalRange) {
  const CLI::Validator diameter = cli::length_in(10e-6, 1.0);
  EXPECT_EQ(refusal<std::string>(diameter, "3mm"), "");
  EXPECT_EQ(refusal<std::string>(diameter, "2.75e-5"), "");
  EXPECT_EQ(refusal<std::string>(diameter, "10m"), "--x: must be a length in [10 um, 1 m], not 10m");
  EXPECT_NE(refusal<std::string>(diameter, "nan").find("must be a finite length"), std::string::npos);
  EXPECT_NE(refusal<std::string>(diameter, "1e999mm").find("too large"), std::string::npos);
  EXPECT_NE(refusal<std::string>(diameter, "3 furlongs").find("unknown unit 'furlongs'"), std::string::npos);
  EXPECT_NE(refusal<std::string>(diameter, "0").find("[10 um, 1 m]"), std::string::npos);
  const CLI::Validator membrane = cli::length_in(1e-6, 0.01, true);
  EXPECT_EQ(refusal<std::string>(membrane, "0"), "");
  EXPECT_EQ(refusal<std::string>(membrane, "0mm"), "") << "zero with a unit is none too";
  EXPECT_NE(refusal<std::string>(diameter, "0mm").find("[10 um, 1 m]"), std::string::npos);
  EXPECT_NE(refusal<std::string>(membrane, "-1mm").find("(or 0 for none)"), std::string::npos);
  const CLI::Validator position = cli::length_in(-1.0, 1.0);
  EXPECT_EQ(refusal<std::string>(position, "-1.5mm"), "") << "positions may be zero or negative";
  EXPECT_EQ(refusal<std::string>(position, "0"), "");
}

TEST(OptionChecks, HelpShowsTheRange) {
  CLI::App app("test");
  double blur = 0.8;
  app.add_option("--blur", blur, "Point-spread sigma")->check(cli::number_in(cli::closed(0, 20, "voxels")));
  EXPECT_NE(app.help().find("[0, 20] voxels"), std::string::npos) << app.help();
}

TEST(OptionChecks, LibraryChecksThrowUsageErrorsNamingTheValue) {
  EXPECT_EQ(cli::require_in(0.5, "--x", cli::closed(0, 1)), 0.5);
  try {
    cli::require_in(std::numeric_limits<double>::quiet_NaN(), "--tol", cli::closed(0, 1));
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--tol must be a finite number in [0, 1], not nan");
  }
  EXPECT_DOUBLE_EQ(cli::parse_length_in("-1.5mm", "--cylinder centre x", -1.0, 1.0), -1.5e-3);
  EXPECT_DOUBLE_EQ(cli::parse_length_in("0", "--cylinder centre x", -1.0, 1.0), 0.0);
  try {
    cli::parse_length_in("2km", "--cylinder radius", 1e-6, 1.0);
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--cylinder radius '2km' has unknown unit 'km'; use m, mm, um or nm");
  }
  try {
    cli::parse_length_in("2m", "--cylinder radius", 1e-6, 1.0);
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--cylinder radius must be a length in [1 um, 1 m], not 2m");
  }
}

TEST(FiniteNumber, RefusesOnlyNanAndInfinities) {
  const CLI::Validator grey = cli::finite_number();
  for (const char* ok : {"-1e30", "0", "65535.5"}) EXPECT_EQ(refusal<double>(grey, ok), "") << ok;
  EXPECT_EQ(refusal<double>(grey, "nan"), "--x: must be a finite number, not nan");
  EXPECT_NE(refusal<double>(grey, "-inf"), "");
  EXPECT_NE(refusal<double>(grey, "1e999"), "");
}
