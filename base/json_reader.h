// The one strict JSON reader of insid (issues 17 and 20): every JSON file insid reads — dataset
// meta.json, scenario and campaign configs, manifests, run files, caches — goes through it.
//
// Strict means RFC 8259 JSON (nlohmann::json's parser: no comments, no NaN/Infinity, no trailing
// commas) plus one rule RFC 8259 leaves open ("names within an object SHOULD be unique"): a key
// that appears twice in one object is an error naming the path of the key (`scenarios[1].grade`),
// instead of the last value silently winning, and no NUL byte (nlohmann's parser would stop there
// and ignore the rest).
//
// Limits (against hostile or broken input): a document nested deeper than max_depth arrays and
// objects, or longer than max_bytes, is refused before it is parsed, with the line, column and byte
// of the first bracket too deep; running out of memory while parsing is an error naming the
// document (never a bare std::bad_alloc). insid's own files nest at most 8 deep and the largest (a
// campaign's summary.json) is about 1 MB; a parsed value takes up to ~25x its text (an empty array:
// 3 bytes of text, a 16-byte value and its allocation), so 64 MiB stays within about 2 GB.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace insid {

inline constexpr std::size_t kJsonMaxDepth = 64;                     ///< nested arrays and objects
inline constexpr std::size_t kJsonMaxBytes = std::size_t{64} << 20;  ///< bytes of one document

struct JsonLimits {
  std::size_t max_depth = kJsonMaxDepth;  ///< the top-level array or object is depth 1
  std::size_t max_bytes = kJsonMaxBytes;
};

/// Parses `text`. Throws std::runtime_error starting with `where` on a syntax error (with
/// nlohmann's line and column), a duplicate key (with its path, in the typed reader's wording,
/// base/json_object.h: `c.json: scenarios[1].grade: key given twice in one object ...`), a
/// document beyond `limits`, or when memory runs out.
nlohmann::json parse_json_strict(std::string_view text, const std::string& where,
                                 const JsonLimits& limits = {});

/// Reads and parses a whole file; `where` defaults to the path. Throws std::runtime_error naming
/// the file when it cannot be read, is larger than limits.max_bytes (checked before reading) or
/// is not strict JSON within the limits.
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& where = "",
                              const JsonLimits& limits = {});

/// What a nlohmann exception says, without its internal tag ("[json.exception.type_error.302] ").
std::string json_error_text(const nlohmann::json::exception& e);

}  // namespace insid
