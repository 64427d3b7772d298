#include "base/json_object.h"

#include <algorithm>
#include <cmath>

#include "base/number_text.h"

namespace insid {
namespace {

using json = nlohmann::json;

constexpr std::size_t kExcerptChars = 60;

std::string cut(std::string text) {
  if (text.size() > kExcerptChars) text = text.substr(0, kExcerptChars) + "...";
  return text;
}

std::string joined(const std::vector<std::string>& names) {
  std::string list;
  for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
  return list;
}

}  // namespace

std::string json_field_message(std::string_view source, std::string_view path,
                               std::string_view what) {
  std::string message(source);
  if (!path.empty()) message += ": " + std::string(path);
  return message + ": " + std::string(what);
}

std::string describe_json_value(const json& value) {
  switch (value.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return value.get<bool>() ? "a boolean true" : "a boolean false";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
      return "a number " + value.dump();
    case json::value_t::number_float:
      return "a number " + number_text(value.get<double>(), 12);
    case json::value_t::string:
      return "a string " + cut(value.dump());
    case json::value_t::array:
      // The strict parser bounds the depth (64), so dump() never recurses deeply; an array of
      // millions of elements is printed whole before it is cut, but only on the way to an error.
      return "an array " + cut(value.dump());
    case json::value_t::object:
      return "an object " + cut(value.dump());
    default:
      return std::string("a ") + value.type_name();
  }
}

std::string json_key_path(std::string_view parent, std::string_view key) {
  return parent.empty() ? std::string(key) : std::string(parent) + "." + std::string(key);
}

std::string json_index_path(std::string_view parent, std::size_t index) {
  return std::string(parent) + "[" + std::to_string(index) + "]";
}

// ----- JsonField ------------------------------------------------------------------------------

void JsonField::fail(std::string_view what) const {
  throw JsonFieldError(json_field_message(source_, path_, what));
}

void JsonField::wrong(std::string_view expected) const {
  if (!value_) fail("missing, expected " + std::string(expected));
  fail("expected " + std::string(expected) + ", found " + describe_json_value(*value_));
}

const json& JsonField::value() const {
  if (!value_) fail("missing");
  return *value_;
}

double JsonField::number() const {
  if (!value_ || !value_->is_number()) wrong("a number");
  return value_->get<double>();
}

double JsonField::finite_number() const {
  if (!value_ || !value_->is_number() || !std::isfinite(value_->get<double>()))
    wrong("a finite number");
  return value_->get<double>();
}

std::int64_t JsonField::integer(std::int64_t lo, std::int64_t hi) const {
  const std::string expected =
      "a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!value_ || !value_->is_number()) wrong(expected);
  const double v = value_->get<double>();
  // Compared as doubles: lo and hi are far inside the 2^53 where doubles count exactly.
  if (!(v == std::floor(v) && v >= static_cast<double>(lo) && v <= static_cast<double>(hi)))
    wrong(expected);
  return static_cast<std::int64_t>(v);
}

bool JsonField::boolean() const {
  if (!value_ || !value_->is_boolean()) wrong("a boolean");
  return value_->get<bool>();
}

std::string JsonField::string() const {
  if (!value_ || !value_->is_string()) wrong("a string");
  return value_->get<std::string>();
}

std::string JsonField::choice(std::initializer_list<std::string_view> choices) const {
  return choice(std::span<const std::string_view>(choices.begin(), choices.size()));
}

std::string JsonField::choice(std::span<const std::string_view> choices) const {
  // "a" or "b"; one of "a", "b", "c"
  std::string expected = choices.size() > 2 ? "one of " : "";
  const std::string_view separator = choices.size() > 2 ? ", " : " or ";
  for (std::size_t i = 0; i < choices.size(); ++i) {
    if (i > 0) expected.append(separator);
    expected.append("\"").append(choices[i]).append("\"");
  }
  if (!value_ || !value_->is_string()) wrong(expected);
  const std::string v = value_->get<std::string>();
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) wrong(expected);
  return v;
}

JsonArray JsonField::array() const {
  if (!value_ || !value_->is_array()) wrong("an array");
  return JsonArray(*value_, source_, path_);
}

JsonObject JsonField::object(std::vector<std::string> keys) const {
  if (!value_) wrong("an object");
  return JsonObject(*value_, source_, path_, std::move(keys));
}

JsonObject JsonField::map() const {
  if (!value_) wrong("an object");
  return JsonObject::any_keys(*value_, source_, path_);
}

// ----- JsonArray ------------------------------------------------------------------------------

JsonArray::JsonArray(const json& value, std::string source, std::string path)
    : value_(&value), source_(std::move(source)), path_(std::move(path)) {
  if (!value.is_array()) JsonField(&value, source_, path_).array();  // throws, naming the type
}

JsonField JsonArray::operator[](std::size_t index) const {
  return JsonField(&(*value_)[index], source_, json_index_path(path_, index));
}

std::vector<double> JsonArray::numbers() const {
  std::vector<double> out;
  out.reserve(size());
  for (std::size_t i = 0; i < size(); ++i) out.push_back((*this)[i].finite_number());
  return out;
}

std::vector<std::string> JsonArray::strings() const {
  std::vector<std::string> out;
  out.reserve(size());
  for (std::size_t i = 0; i < size(); ++i) out.push_back((*this)[i].string());
  return out;
}

void JsonArray::fail(std::string_view what) const {
  throw JsonFieldError(json_field_message(source_, path_, what));
}

// ----- JsonObject -----------------------------------------------------------------------------

JsonObject::JsonObject(const json& value, std::string source, std::string path,
                       std::vector<std::string> keys)
    : JsonObject(value, std::move(source), std::move(path),
                 std::optional<std::vector<std::string>>(std::move(keys)), true) {}

JsonObject JsonObject::any_keys(const json& value, std::string source, std::string path) {
  return JsonObject(value, std::move(source), std::move(path), std::nullopt, false);
}

JsonObject::JsonObject(const json& value, std::string source, std::string path,
                       std::optional<std::vector<std::string>> keys, bool refuse_others)
    : value_(&value), source_(std::move(source)), path_(std::move(path)), keys_(std::move(keys)) {
  if (!value.is_object())
    throw JsonFieldError(json_field_message(
        source_, path_, "expected an object, found " + describe_json_value(value)));
  if (!keys_ || !refuse_others) return;
  for (const auto& item : value.items())
    if (std::find(keys_->begin(), keys_->end(), item.key()) == keys_->end())
      fail(item.key(), "unknown key (valid keys: " + joined(*keys_) + ")");
}

void JsonObject::check_declared(std::string_view key) const {
  if (keys_ && std::find(keys_->begin(), keys_->end(), key) == keys_->end())
    throw std::logic_error(
        json_field_message(source_, path_of(key), "read but not among the object's declared keys"));
}

bool JsonObject::has(std::string_view key) const {
  check_declared(key);
  return value_->contains(key);
}

bool JsonObject::given(std::string_view key) const {
  check_declared(key);
  const auto it = value_->find(key);
  return it != value_->end() && !it->is_null();
}

JsonField JsonObject::field(std::string_view key) const {
  check_declared(key);
  const auto it = value_->find(key);
  return JsonField(it == value_->end() ? nullptr : &*it, source_, path_of(key));
}

std::optional<JsonField> JsonObject::optional(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return field(key);
}

std::optional<JsonField> JsonObject::optional_given(std::string_view key) const {
  if (!given(key)) return std::nullopt;
  return field(key);
}

double JsonObject::number(std::string_view key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

std::optional<double> JsonObject::optional_number(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return number(key);
}

std::string JsonObject::string(std::string_view key, const std::string& fallback) const {
  return has(key) ? string(key) : fallback;
}

void JsonObject::fail(std::string_view what) const {
  throw JsonFieldError(json_field_message(source_, path_, what));
}

void JsonObject::fail(std::string_view key, std::string_view what) const {
  throw JsonFieldError(json_field_message(source_, path_of(key), what));
}

}  // namespace insid
