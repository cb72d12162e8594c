#include <gtest/gtest.h>

#include "pplvo/core/enum_names.h"

namespace pplvo {
namespace {

enum class Colour { kRed, kGreen, kBlue, kUnlisted };

constexpr EnumName<Colour> kColourNames[] = {{Colour::kRed, "red"},
                                             {Colour::kGreen, "green"},
                                             {Colour::kGreen, "lime"},
                                             {Colour::kBlue, "blue"}};

TEST(EnumNames, NameIsTheFirstRowOfAValue) {
  static_assert(std::string_view(enumName(kColourNames, Colour::kBlue)) == "blue");
  EXPECT_STREQ(enumName(kColourNames, Colour::kRed), "red");
  EXPECT_STREQ(enumName(kColourNames, Colour::kGreen), "green");  // not the alias
  EXPECT_STREQ(enumName(kColourNames, Colour::kUnlisted), "?");
  EXPECT_STREQ(enumName(kColourNames, Colour::kUnlisted, "unknown"), "unknown");
}

TEST(EnumNames, ParseNamesAndAliases) {
  EXPECT_EQ(parseEnum(kColourNames, "red"), Colour::kRed);
  EXPECT_EQ(parseEnum(kColourNames, "lime"), Colour::kGreen);
  EXPECT_EQ(parseEnum(kColourNames, "blue"), Colour::kBlue);
  EXPECT_FALSE(parseEnum(kColourNames, "Blue").has_value());
  EXPECT_FALSE(parseEnum(kColourNames, "").has_value());
  EXPECT_FALSE(parseEnum(kColourNames, "blu").has_value());
  EXPECT_FALSE(parseEnum(kColourNames, "bluee").has_value());
  EXPECT_EQ(parseEnum(kColourNames, "BLUE", EnumCase::kIgnore), Colour::kBlue);
  EXPECT_EQ(parseEnum(kColourNames, "Lime", EnumCase::kIgnore), Colour::kGreen);
}

TEST(EnumNames, OutParameterIsOnlySetOnSuccess) {
  Colour c = Colour::kUnlisted;
  EXPECT_FALSE(parseEnum(kColourNames, "purple", &c));
  EXPECT_EQ(c, Colour::kUnlisted);
  EXPECT_TRUE(parseEnum(kColourNames, "green", &c));
  EXPECT_EQ(c, Colour::kGreen);
}

TEST(EnumNames, ChoicesListEachValueOnce) {
  EXPECT_EQ(enumChoices(kColourNames), "red|green|blue");
  EXPECT_EQ(enumChoices(kColourNames, ", "), "red, green, blue");
}

TEST(EnumNames, EveryNameParsesBackToItsValue) {
  for (const EnumName<Colour>& row : kColourNames) {
    EXPECT_EQ(parseEnum(kColourNames, row.name), row.value) << row.name;
    EXPECT_EQ(parseEnum(kColourNames, enumName(kColourNames, row.value)), row.value);
  }
}

}  // namespace
}  // namespace pplvo
