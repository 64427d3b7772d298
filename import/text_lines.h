// Line-by-line reading of a text file held in memory, with 1-based line numbers for the error
// messages of the text importers (csv, kf-gins, rtklib-pos).
#pragma once

#include <cstddef>
#include <string_view>

namespace insid::importers {

class TextLines {
 public:
  explicit TextLines(std::string_view text) : text_(text) {}

  /// The next line without its '\n' (a '\r' before it is kept; each parser's field splitting
  /// decides about it) and its number counted from 1; false after the last line. A final line
  /// without '\n' is returned; an empty text has no lines.
  bool next(std::string_view* line, std::size_t* line_no) {
    if (pos_ >= text_.size()) return false;
    const std::size_t nl = text_.find('\n', pos_);
    const std::size_t end = nl == std::string_view::npos ? text_.size() : nl;
    *line = text_.substr(pos_, end - pos_);
    pos_ = nl == std::string_view::npos ? text_.size() : nl + 1;
    *line_no = ++line_no_;
    return true;
  }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_no_ = 0;
};

}  // namespace insid::importers
