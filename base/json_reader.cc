#include "base/json_reader.h"

#include <cstdint>
#include <fstream>
#include <new>
#include <set>
#include <stdexcept>
#include <vector>

namespace insid {
namespace {

using json = nlohmann::json;

// One open object or array while parsing, for duplicate detection and for naming where we are.
struct Frame {
  bool is_object = false;
  std::string path;            // "" for the top level
  std::set<std::string> keys;  // objects: keys seen so far
  std::string last_key;        // objects: the key whose value is being parsed
  std::size_t index = 0;       // arrays: index of the element being parsed
};

std::string byte_size_error(const std::string& where, std::size_t bytes, const JsonLimits& limits) {
  return where + ": " + std::to_string(bytes) + " bytes, more than the limit of " +
         std::to_string(limits.max_bytes) + " bytes of a JSON document";
}

// The nesting depth, in one pass over the bytes without allocating: brackets inside strings do
// not count (a backslash escapes the next byte). Throws at the first bracket beyond the limit,
// before anything is parsed; everything else (balance, syntax) is the parser's to judge, except a
// NUL byte, which nlohmann's parser takes as the end of the input (so "{}\0anything" would pass):
// JSON text has none (RFC 8259: control characters in strings are escaped).
void check_depth_and_nul(std::string_view text, const std::string& where,
                         const JsonLimits& limits) {
  std::size_t depth = 0, line = 1, line_start = 0;
  bool in_string = false;
  const auto at = [&](std::size_t i) {
    return where + ": line " + std::to_string(line) + ", column " +
           std::to_string(i - line_start + 1) + " (byte " + std::to_string(i) + "): ";
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\0')
      throw std::runtime_error(at(i) + "a NUL byte, which JSON text never holds (not valid JSON)");
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
      continue;
    }
    switch (c) {
      case '"':
        in_string = true;
        break;
      case '\n':
        ++line;
        line_start = i + 1;
        break;
      case '[':
      case '{':
        if (++depth > limits.max_depth)
          throw std::runtime_error(at(i) + "nesting depth " + std::to_string(depth) +
                                   " exceeds the limit of " + std::to_string(limits.max_depth) +
                                   " nested arrays and objects");
        break;
      case ']':
      case '}':
        if (depth > 0) --depth;
        break;
      default:
        break;
    }
  }
}

std::string child_path(const std::vector<Frame>& stack) {
  if (stack.empty()) return "";
  const Frame& parent = stack.back();
  if (parent.is_object)
    return parent.path.empty() ? parent.last_key : parent.path + "." + parent.last_key;
  return parent.path + "[" + std::to_string(parent.index) + "]";
}

}  // namespace

json parse_json_strict(std::string_view text, const std::string& where, const JsonLimits& limits) {
  if (text.size() > limits.max_bytes)
    throw std::runtime_error(byte_size_error(where, text.size(), limits));
  check_depth_and_nul(text, where, limits);
  std::vector<Frame> stack;
  const auto element_done = [&stack] {
    if (!stack.empty() && !stack.back().is_object) ++stack.back().index;
  };
  const json::parser_callback_t check = [&](int /*depth*/, json::parse_event_t event,
                                            json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start: {
        Frame f;
        f.is_object = event == json::parse_event_t::object_start;
        f.path = child_path(stack);
        stack.push_back(std::move(f));
        break;
      }
      case json::parse_event_t::key: {
        Frame& top = stack.back();
        top.last_key = parsed.get<std::string>();
        // The wording of the typed reader (base/json_object.h): the source, the field's path.
        if (!top.keys.insert(top.last_key).second)
          throw std::runtime_error(
              where + ": " + (top.path.empty() ? top.last_key : top.path + "." + top.last_key) +
              ": key given twice in one object (JSON objects must not repeat a key)");
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        stack.pop_back();
        element_done();
        break;
      case json::parse_event_t::value:
        element_done();
        break;
    }
    return true;
  };
  try {
    return json::parse(text.begin(), text.end(), check);
  } catch (const json::exception& e) {
    // parse_error (syntax) and out_of_range (a number beyond double, e.g. 1e999), with nlohmann's
    // line and column where it gives them (without nlohmann's "[json.exception...]" tag, which
    // means nothing to a user).
    throw std::runtime_error(where + ": not valid JSON: " + json_error_text(e));
  } catch (const std::bad_alloc&) {
    // The partial value is freed by now (nlohmann frees it without recursion; on an array of
    // millions of elements that itself allocates, and a failure there terminates).
    throw std::runtime_error(where + ": out of memory parsing a JSON document of " +
                             std::to_string(text.size()) +
                             " bytes (its parsed value takes many times its size)");
  }
}

std::string json_error_text(const nlohmann::json::exception& e) {
  // "[json.exception.parse_error.101] parse error at line 3, ...": the tag means nothing to a user.
  std::string what = e.what();
  if (what.rfind("[json.exception.", 0) == 0)
    if (const std::size_t end = what.find("] "); end != std::string::npos) what.erase(0, end + 2);
  return what;
}

json read_json_file(const std::filesystem::path& path, const std::string& where,
                    const JsonLimits& limits) {
  const std::string name = where.empty() ? path.string() : where;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw std::runtime_error(name + ": is a directory, expected a JSON file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(name + ": cannot open for reading");
  // The size before reading (a regular file; a pipe or device is bounded while reading).
  if (const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
      !ec && bytes > limits.max_bytes)
    throw std::runtime_error(byte_size_error(name, static_cast<std::size_t>(bytes), limits));
  std::string text;
  char chunk[65536];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (text.size() > limits.max_bytes)
      throw std::runtime_error(name + ": more than the limit of " +
                               std::to_string(limits.max_bytes) + " bytes of a JSON document");
  }
  if (in.bad()) throw std::runtime_error(name + ": read error");
  return parse_json_strict(text, name, limits);
}

}  // namespace insid
