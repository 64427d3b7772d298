#include "core/json_reader.h"

#include <fstream>
#include <set>
#include <sstream>
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

std::string child_path(const std::vector<Frame>& stack) {
  if (stack.empty()) return "";
  const Frame& parent = stack.back();
  if (parent.is_object)
    return parent.path.empty() ? parent.last_key : parent.path + "." + parent.last_key;
  return parent.path + "[" + std::to_string(parent.index) + "]";
}

}  // namespace

json parse_json_strict(std::string_view text, const std::string& where) {
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
        if (!top.keys.insert(top.last_key).second)
          throw std::runtime_error(
              where + ": key \"" + top.last_key + "\" appears twice in " +
              (top.path.empty() ? "the top-level object" : "object \"" + top.path + "\"") +
              " (JSON objects must not repeat a key)");
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
    // line and column where it gives them.
    throw std::runtime_error(where + ": not valid JSON: " + e.what());
  }
}

json read_json_file(const std::filesystem::path& path, const std::string& where) {
  const std::string name = where.empty() ? path.string() : where;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw std::runtime_error(name + ": is a directory, expected a JSON file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(name + ": cannot open for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error(name + ": read error");
  return parse_json_strict(text.str(), name);
}

}  // namespace insid
