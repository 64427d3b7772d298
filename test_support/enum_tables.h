// GoogleTest checks of an enum's name table (base/enum_table.h): both directions and the error
// for an unknown name.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "base/enum_table.h"

namespace insid::test {

/// `names`: every value with the name written for it (the first of its names). Expects
/// name(value) == name and value(name) == value for each, every name of the table to lead back
/// to a value whose name is listed, and an unknown name refused with std::invalid_argument
/// naming every name of the table.
template <class E, std::size_t N>
void expect_enum_table(const EnumTable<E, N>& table,
                       const std::vector<std::pair<E, std::string>>& names) {
  for (const auto& [value, name] : names) {
    EXPECT_EQ(table.name(value), name);
    EXPECT_EQ(table.value(name), value) << name;
  }
  for (const std::string_view name : table.names()) {
    const E value = table.value(name);
    bool listed = false;
    for (const auto& [v, n] : names) listed = listed || v == value;
    EXPECT_TRUE(listed) << name;
  }
  std::string message;
  try {
    (void)table.value("no-such-name");
  } catch (const std::invalid_argument& e) {
    message = e.what();
  }
  EXPECT_EQ(message,
            std::string(table.what) + " must be " + table.quoted_names() + ", got 'no-such-name'");
  for (const std::string_view name : table.names())
    EXPECT_NE(message.find("'" + std::string(name) + "'"), std::string::npos) << name;
}

}  // namespace insid::test
