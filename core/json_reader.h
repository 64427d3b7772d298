// The one strict JSON reader of insid (issues 17 and 20): every JSON file insid reads — dataset
// meta.json, scenario and campaign configs, manifests, run files, caches — goes through it.
//
// Strict means RFC 8259 JSON (nlohmann::json's parser: no comments, no NaN/Infinity, no trailing
// commas) plus one rule RFC 8259 leaves open ("names within an object SHOULD be unique"): a key
// that appears twice in one object is an error naming the key and the object it is in, instead of
// the last value silently winning.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace insid {

/// Parses `text`. Throws std::runtime_error starting with `where` on a syntax error (with
/// nlohmann's line and column) or a duplicate key (with its path, e.g. `scenarios[1].imu`).
nlohmann::json parse_json_strict(std::string_view text, const std::string& where);

/// Reads and parses a whole file; `where` defaults to the path. Throws std::runtime_error naming
/// the file when it cannot be read or is not strict JSON.
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& where = "");

}  // namespace insid
