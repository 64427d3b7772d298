#include "base/number_text.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <system_error>

namespace insid {

std::string number_text(double value, int digits, Digits kind) {
  digits = std::max(digits, 0);
  const char* format = kind == Digits::kAfterPoint ? "%.*f" : "%.*g";
  char buffer[64];
  const int n = std::snprintf(buffer, sizeof buffer, format, digits, value);
  if (n < 0) return "?";
  if (static_cast<std::size_t>(n) < sizeof buffer) return std::string(buffer, buffer + n);
  std::string text(static_cast<std::size_t>(n) + 1, '\0');  // a long "%f" of a huge value
  std::snprintf(text.data(), text.size(), format, digits, value);
  text.resize(static_cast<std::size_t>(n));
  return text;
}

std::string number_text(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return ec == std::errc() ? std::string(buffer, end) : std::string("?");
}

}  // namespace insid
