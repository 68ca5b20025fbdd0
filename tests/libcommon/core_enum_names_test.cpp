// One table per enum (core/enum_names.hpp): names and parsing read the same table, and an unknown
// name is refused naming every known one.
#include <gtest/gtest.h>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/volume.hpp"

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

TEST(EnumNames, AnOptionListsTheNamesItsParsingTakes) {
  EXPECT_EQ(enum_names(kColours), (std::vector<std::string>{"red", "green", "blue"}));
  for (const std::string& name : enum_names(kColours)) EXPECT_STREQ(enum_name(kColours, parse_enum(kColours, name, "colour")), name.c_str());
}

TEST(EnumNames, FindEnumIsExactAndMayFindNothing) {
  EXPECT_EQ(find_enum(kColours, "green"), Colour::green);
  EXPECT_FALSE(find_enum(kColours, "Green").has_value());
  EXPECT_FALSE(find_enum(kColours, "").has_value());
}

TEST(EnumNames, VoxelTypesReadTheirOwnNamesAndTheUsersShortOnes) {
  for (DType t : {DType::uint8, DType::uint16, DType::uint32, DType::float32}) {
    EXPECT_EQ(dtype_named(dtype_name(t)), t);  // the names files carry
    EXPECT_EQ(parse_dtype(dtype_name(t)), t);
  }
  EXPECT_EQ(parse_dtype(" U16 "), DType::uint16);
  EXPECT_EQ(parse_dtype("float"), DType::float32);
  EXPECT_FALSE(dtype_named("u16").has_value());  // a file's element type goes by its full name
  EXPECT_FALSE(dtype_named("int16").has_value());
  try {
    parse_dtype("int7");
    FAIL() << "int7 parsed";
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "unknown data type 'int7' is not uint8, uint16, uint32 or float32");
  }
}
