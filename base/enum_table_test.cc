// The enum name table: both directions, aliases, the unknown-name message, and JsonField::choice
// reading a table's value.
#include "base/enum_table.h"

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "base/json_object.h"
#include "test_support/enum_tables.h"
#include "test_support/errors.h"

namespace insid {
namespace {

enum class Colour { kRed, kGreen, kBlue, kUnnamed };

constexpr EnumTable<Colour, 4> kColours{"colour",
                                        {{{Colour::kRed, "red"},
                                          {Colour::kGreen, "green"},
                                          {Colour::kGreen, "verde"},  // an alias
                                          {Colour::kBlue, "blue"}}}};

TEST(EnumTable, BothDirectionsWithAnAlias) {
  test::expect_enum_table(
      kColours, {{Colour::kRed, "red"}, {Colour::kGreen, "green"}, {Colour::kBlue, "blue"}});
  EXPECT_EQ(kColours.value("verde"), Colour::kGreen);
  EXPECT_EQ(kColours.name(Colour::kGreen), "green");  // the first name, not the alias
  static_assert(kColours.name(Colour::kBlue) == "blue");
  static_assert(kColours.find("verde") == Colour::kGreen);
  static_assert(!kColours.find("Red").has_value());  // names are exact
}

TEST(EnumTable, UnknownNameListsEveryName) {
  EXPECT_EQ(test::error_of([] { (void)kColours.value("purple"); }),
            "colour must be 'red', 'green', 'verde' or 'blue', got 'purple'");
  constexpr EnumTable<Colour, 2> two{"colour", {{{Colour::kRed, "red"}, {Colour::kBlue, "blue"}}}};
  EXPECT_EQ(two.quoted_names(), "'red' or 'blue'");
  constexpr EnumTable<Colour, 1> one{"colour", {{{Colour::kRed, "red"}}}};
  EXPECT_EQ(one.quoted_names(), "'red'");
}

TEST(EnumTable, AValueWithoutANameIsALogicError) {
  EXPECT_THROW((void)kColours.name(Colour::kUnnamed), std::logic_error);
}

TEST(EnumTable, JsonChoiceReadsTheTablesValueAndRefusesOtherNames) {
  const nlohmann::json doc = {{"c", "verde"}, {"d", "purple"}};
  const JsonObject object(doc, "x.json", "", {"c", "d"});
  EXPECT_EQ(object.field("c").choice(kColours), Colour::kGreen);
  EXPECT_THROW((void)object.field("d").choice(kColours), JsonFieldError);
  EXPECT_NE(test::error_of([&] {
              (void)object.field("d").choice(kColours);
            }).find("one of \"red\", \"green\", \"verde\", \"blue\""),
            std::string::npos);
}

}  // namespace
}  // namespace insid
