// One table per enum (core/enum_names.hpp): names and parsing read the same table, and an unknown
// name is refused naming every known one.
#include <gtest/gtest.h>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"

using namespace graintwin;

namespace {
enum class Colour { red, green, blue, unnamed };
constexpr std::array<EnumName<Colour>, 3> kColours{{{Colour::red, "red"}, {Colour::green, "green"}, {Colour::blue, "blue"}}};
}  // namespace

TEST(EnumNames, EveryNameParsesBackToItsValue) {
  for (const auto& e : kColours) EXPECT_EQ(parse_enum(kColours, enum_name(kColours, e.value), "colour"), e.value);
  EXPECT_STREQ(enum_name(kColours, Colour::unnamed), "?");
}

TEST(EnumNames, AnUnknownNameIsAUsageErrorListingTheKnownOnes) {
  try {
    parse_enum(kColours, "mauve", "--colour");
    FAIL() << "mauve parsed";
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--colour 'mauve' is not red, green or blue");
  }
  EXPECT_THROW(parse_enum(kColours, "Red", "--colour"), UsageError);  // names are exact
}
