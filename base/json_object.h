// The one typed reader of JSON objects: every config and meta reader of insid —
// dataset meta.json, scenario files, campaign configs — and the external-optimizer protocol's
// replies read their fields through it, on top of the one strict parser (base/json_reader.h).
//
// One wording for every error, naming the source, the path of the field inside it, what was
// expected and what was found:
//
//   campaign.json: scenarios[1].flight_s: expected a number, found a string "long"
//   campaign.json: scenarios[1].name: missing, expected a string
//   campaign.json: scenarios[1].colour: unknown key (valid keys: name, preset, data)
//   campaign.json: seeds[0]: expected a whole number in [0, 1000000000], found a number 1.5
//   /data/run1: meta.json: align_s: key given twice in one object (JSON objects must not ...)
//
// (the last one from the strict parser, which refuses a key given twice before any reader sees
// the document). A check of a value's meaning made by the caller uses the same form through
// fail(): `campaign.json: scenarios[0].flight_s: must be > 0 s, found -1`. The top level has no
// path: `campaign.json: expected an object, found an array [1,2]`.
//
// The reader is a view: the value it reads must outlive it. Errors are JsonFieldError (an
// std::invalid_argument: a config or a file's content is an argument to insid); readers whose
// contract is another type (DatasetError) catch and rethrow it with the same text.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/enum_table.h"

namespace insid {

/// An error in a JSON document's content: "<source>: <path>: <what>".
class JsonFieldError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The one wording: "<source>: <path>: <what>", or "<source>: <what>" for the top level (an empty
/// path).
std::string json_field_message(std::string_view source, std::string_view path,
                               std::string_view what);

/// What a value is, for "found ...": `a string "x"`, `a number 1.5`, `a boolean true`, `null`,
/// `an array [1,2]`, `an object {"a":1}`; arrays, objects and strings cut after 60 characters.
std::string describe_json_value(const nlohmann::json& value);

/// "scenarios" + "name" -> "scenarios.name"; "" + "name" -> "name".
std::string json_key_path(std::string_view parent, std::string_view key);
/// "scenarios" + 1 -> "scenarios[1]".
std::string json_index_path(std::string_view parent, std::size_t index);

class JsonObject;
class JsonArray;

/// One value of a document at its path, to be read as a type. A field that is absent (from
/// JsonObject::field) is refused by every reading as "missing, expected <type>".
class JsonField {
 public:
  JsonField(const nlohmann::json* value, std::string source, std::string path)
      : value_(value), source_(std::move(source)), path_(std::move(path)) {}

  bool present() const { return value_ != nullptr; }
  bool is_null() const { return value_ != nullptr && value_->is_null(); }
  /// The value as it is (required: throws "missing" when absent).
  const nlohmann::json& value() const;

  /// Any JSON number (in a document the strict parser read, always finite; an in-memory value
  /// may hold NaN).
  double number() const;
  /// A finite JSON number.
  double finite_number() const;
  /// A whole number in [lo, hi] (written as 3 or 3.0).
  std::int64_t integer(std::int64_t lo, std::int64_t hi) const;
  bool boolean() const;
  std::string string() const;
  /// A string, one of `choices`; refused naming them.
  std::string choice(std::initializer_list<std::string_view> choices) const;
  std::string choice(std::span<const std::string_view> choices) const;
  /// The value of `table` (base/enum_table.h) the string names; refused naming every name.
  template <class E, std::size_t N>
  E choice(const EnumTable<E, N>& table) const {
    const std::array<std::string_view, N> names = table.names();
    return table.value(choice(std::span<const std::string_view>(names)));
  }
  JsonArray array() const;
  /// An object whose keys are among `keys` (an unknown key refused, naming the valid ones).
  JsonObject object(std::vector<std::string> keys) const;
  /// An object with any keys (a map such as "injected": the caller checks the names).
  JsonObject map() const;

  /// Throws JsonFieldError "<source>: <path>: <what>".
  [[noreturn]] void fail(std::string_view what) const;

  const std::string& source() const { return source_; }
  const std::string& path() const { return path_; }

 private:
  /// "expected <expected>, found <the value>", or "missing, expected <expected>".
  [[noreturn]] void wrong(std::string_view expected) const;

  const nlohmann::json* value_;
  std::string source_;
  std::string path_;
};

/// An array of a document at its path; its elements read as JsonFields ("scenarios[2]").
class JsonArray {
 public:
  JsonArray(const nlohmann::json& value, std::string source, std::string path);

  std::size_t size() const { return value_->size(); }
  bool empty() const { return value_->empty(); }
  JsonField operator[](std::size_t index) const;
  const nlohmann::json& value() const { return *value_; }

  /// Every element a finite number, else the first that is not is named.
  std::vector<double> numbers() const;
  std::vector<std::string> strings() const;

  [[noreturn]] void fail(std::string_view what) const;
  const std::string& source() const { return source_; }
  const std::string& path() const { return path_; }

 private:
  const nlohmann::json* value_;
  std::string source_;
  std::string path_;
};

/// An object of a document at its path, whose keys are declared up front: a key outside them is
/// refused at construction, naming the valid ones, before any field is read (a misspelt key is
/// named as such, not as the required key it was meant to be).
class JsonObject {
 public:
  /// `value` read as an object at `path` of `source` with the keys `keys`.
  JsonObject(const nlohmann::json& value, std::string source, std::string path,
             std::vector<std::string> keys);
  /// A whole document: the top level, path "".
  static JsonObject document(const nlohmann::json& value, std::string source,
                             std::vector<std::string> keys) {
    return JsonObject(value, std::move(source), "", std::move(keys));
  }
  /// An object with any keys (a map).
  static JsonObject any_keys(const nlohmann::json& value, std::string source, std::string path);
  /// An object whose keys `keys` are read and any other key is left alone: only for a format
  /// that promises it (meta.json's top level, where a hand-made dataset may keep its notes).
  static JsonObject with_other_keys(const nlohmann::json& value, std::string source,
                                    std::string path, std::vector<std::string> keys) {
    return JsonObject(value, std::move(source), std::move(path), std::move(keys), false);
  }

  /// The key is in the object (with any value, null included).
  bool has(std::string_view key) const;
  /// The key is in the object with a value other than null (where null means "not given").
  bool given(std::string_view key) const;

  /// The field `key` (absent: every reading of it says "missing").
  JsonField field(std::string_view key) const;
  /// The field when present, else nullopt.
  std::optional<JsonField> optional(std::string_view key) const;
  /// The field when present and not null, else nullopt.
  std::optional<JsonField> optional_given(std::string_view key) const;

  // The common readings, required and with a fallback.
  double number(std::string_view key) const { return field(key).finite_number(); }
  double number(std::string_view key, double fallback) const;
  std::optional<double> optional_number(std::string_view key) const;
  std::string string(std::string_view key) const { return field(key).string(); }
  std::string string(std::string_view key, const std::string& fallback) const;
  JsonArray array(std::string_view key) const { return field(key).array(); }
  JsonObject object(std::string_view key, std::vector<std::string> keys) const {
    return field(key).object(std::move(keys));
  }

  /// The object itself (a map's keys and values, sorted by key as nlohmann::json keeps them).
  const nlohmann::json& value() const { return *value_; }

  /// Throws JsonFieldError for the object itself: "<source>: <path>: <what>".
  [[noreturn]] void fail(std::string_view what) const;
  /// Throws JsonFieldError for its field `key`: "<source>: <path>.<key>: <what>".
  [[noreturn]] void fail(std::string_view key, std::string_view what) const;

  const std::string& source() const { return source_; }
  const std::string& path() const { return path_; }
  std::string path_of(std::string_view key) const { return json_key_path(path_, key); }

 private:
  /// `keys` nullopt: any keys; else the keys read, and others refused when `refuse_others`.
  JsonObject(const nlohmann::json& value, std::string source, std::string path,
             std::optional<std::vector<std::string>> keys, bool refuse_others);
  /// A programming error: reading a key not declared (the declared list is the valid keys the
  /// messages name, so every key read must be in it).
  void check_declared(std::string_view key) const;

  const nlohmann::json* value_;
  std::string source_;
  std::string path_;
  std::optional<std::vector<std::string>> keys_;  ///< nullopt: any keys
};

}  // namespace insid
