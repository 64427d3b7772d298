// The one number formatter for messages, reports and text files: every place that
// prints a double with a chosen number of digits calls it, so "12 significant digits" means the
// same text everywhere.
#pragma once

#include <string>

namespace insid {

/// How number_text counts its digits.
enum class Digits {
  kSignificant,  ///< printf "%.*g" (an ostream's precision()): trailing zeros dropped, an
                 ///< exponent where the number is very large or small ("0.123", "1e-07")
  kAfterPoint,   ///< printf "%.*f" (std::fixed with precision()): exactly that many digits after
                 ///< the point ("2.50", "12.000000")
};

/// `value` as text with `digits` digits of the `kind` asked for: number_text(0.1234, 3) = "0.123",
/// number_text(2.5, 2, Digits::kAfterPoint) = "2.50". The same text as an std::ostream with
/// precision(digits) (and std::fixed for kAfterPoint) writes; "inf", "-inf", "nan" for those.
/// `digits` < 0 is taken as 0.
std::string number_text(double value, int digits, Digits kind = Digits::kSignificant);

/// The shortest text that reads back to the same double ("0.05", "1.7", "1e-07", "nan").
std::string number_text(double value);

}  // namespace insid
