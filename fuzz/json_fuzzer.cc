// libFuzzer target for the strict JSON reader's limits (base/json_reader.h): the input
// is the document. parse_json_strict must accept it or throw std::runtime_error, and its depth
// check must agree with nlohmann's own parser: a document nlohmann accepts is refused for its
// depth exactly when it nests deeper than kJsonMaxDepth (counted by a SAX pass, no DOM), and an
// accepted value nests at most kJsonMaxDepth deep. Any other exception, a disagreement, a crash
// or a sanitizer report is a finding. base/json_reader.cc is compiled into this target, so the
// reader itself is instrumented for coverage.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/json_reader.h"

namespace {

using json = nlohmann::json;

// The deepest nesting nlohmann's SAX parser reaches; `valid` false on a syntax error.
struct DepthSax : nlohmann::json_sax<json> {
  std::size_t depth = 0, deepest = 0;
  bool valid = true;
  bool open() {
    deepest = std::max(deepest, ++depth);
    return true;
  }
  bool close() {
    --depth;
    return true;
  }
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return open(); }
  bool key(string_t&) override { return true; }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(); }
  bool end_array() override { return close(); }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    valid = false;
    return false;
  }
};

// The nesting depth of a parsed value, without recursion.
std::size_t depth_of(const json& root) {
  std::size_t deepest = 0;
  std::vector<std::pair<const json*, std::size_t>> stack = {{&root, 1}};
  while (!stack.empty()) {
    const auto [v, d] = stack.back();
    stack.pop_back();
    if (!v->is_structured()) continue;
    deepest = std::max(deepest, d);
    for (const json& child : *v) stack.emplace_back(&child, d + 1);
  }
  return deepest;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  DepthSax sax;
  json::sax_parse(text.begin(), text.end(), &sax);
  // nlohmann stops at a NUL byte (end of input); the strict reader refuses one.
  const bool nlohmann_accepts = sax.valid && text.find('\0') == std::string_view::npos;
  std::string refused;
  try {
    const json j = insid::parse_json_strict(text, "fuzz.json");
    if (!nlohmann_accepts) {
      std::fprintf(stderr, "finding: accepted what nlohmann refuses\n");
      std::abort();
    }
    if (depth_of(j) > insid::kJsonMaxDepth) {
      std::fprintf(stderr, "finding: accepted a value %zu deep\n", depth_of(j));
      std::abort();
    }
  } catch (const std::runtime_error& e) {
    refused = e.what();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: not a runtime_error: %s\n", e.what());
    std::abort();
  }
  const bool refused_for_depth = refused.find("nesting depth") != std::string::npos;
  if (nlohmann_accepts && refused_for_depth != (sax.deepest > insid::kJsonMaxDepth)) {
    std::fprintf(stderr, "finding: depth %zu, refused for depth: %d (%s)\n", sax.deepest,
                 refused_for_depth, refused.c_str());
    std::abort();
  }
  return 0;
}
