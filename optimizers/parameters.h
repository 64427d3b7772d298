// Named algorithm parameters: list them (for JSON / --help), set them by name (for a CLI
// `--param KEY=VALUE`), reject unknown names with the list of valid ones.
//
// A parameter struct `P` declares
//   static constexpr std::string_view kAlgorithm = "PSO";
//   static std::span<const ParameterField<P>> fields();
// and gets list / set / from_map from the templates below. Integer parameters (population
// sizes, 0/1 switches) are set from doubles that must be whole numbers.
#pragma once

#include <cmath>
#include <limits>
#include <map>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "base/number_text.h"

namespace insid::opt {

/// Parameter names and values, in declaration order.
using ParameterList = std::vector<std::pair<std::string, double>>;
/// Overrides by name (e.g. parsed from `--param KEY=VALUE`).
using ParameterMap = std::map<std::string, double>;

/// Shortest text that reads back to the same double ("0.05", "1.7", "nan").
inline std::string format_number(double value) { return number_text(value); }

/// "[0.1, -0.25, 3]".
inline std::string format_vector(const Eigen::VectorXd& x) {
  std::string text = "[";
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    if (j > 0) text += ", ";
    text += format_number(x[j]);
  }
  return text + "]";
}

/// What a parameter's value measures, so that a front end that takes values in the problem's own
/// units knows which to convert.
enum class ParameterUnit {
  kPlain,        ///< a count, factor, probability, switch or fraction, or a value in units of its
                 ///< own (named in its description): never converted
  kBoxDistance,  ///< a distance in the problem's box (normalised units): a problem whose box is a
                 ///< scaled physical range may take it in that range's units
};

template <class Params>
struct ParameterField {
  std::string_view name;
  std::variant<double Params::*, int Params::*> member;
  std::string_view description;
  ParameterUnit unit = ParameterUnit::kPlain;
};

/// One parameter of an algorithm: name, value (the default in a registry listing) and unit.
struct ParameterInfo {
  std::string name;
  double value = 0.0;
  ParameterUnit unit = ParameterUnit::kPlain;
  bool operator==(const ParameterInfo&) const = default;
};
using ParameterInfoList = std::vector<ParameterInfo>;

template <class Params>
ParameterList list_parameters(const Params& params) {
  ParameterList list;
  for (const ParameterField<Params>& field : Params::fields()) {
    const double value =
        std::visit([&](auto member) { return static_cast<double>(params.*member); }, field.member);
    list.emplace_back(std::string(field.name), value);
  }
  return list;
}

template <class Params>
ParameterInfoList list_parameter_info(const Params& params) {
  ParameterInfoList list;
  for (const ParameterField<Params>& field : Params::fields()) {
    const double value =
        std::visit([&](auto member) { return static_cast<double>(params.*member); }, field.member);
    list.push_back({std::string(field.name), value, field.unit});
  }
  return list;
}

template <class Params>
std::string parameter_names(const Params&) {
  std::string names;
  for (const ParameterField<Params>& field : Params::fields()) {
    if (!names.empty()) names += ", ";
    names += field.name;
  }
  return names;
}

/// Largest magnitude of an integer parameter: population sizes and counts beyond it would
/// exhaust memory (a population of 1e9 points) long before they could help.
inline constexpr int kMaxIntegerParameter = 1'000'000;

/// Sets one parameter by name; throws std::invalid_argument naming the algorithm, the key and
/// the valid keys (unknown key) or the value (integer parameter given a fraction, or beyond
/// kMaxIntegerParameter). Does not validate ranges: call validate() after all overrides.
template <class Params>
void set_parameter(Params& params, std::string_view name, double value) {
  for (const ParameterField<Params>& field : Params::fields()) {
    if (field.name != name) continue;
    if (auto* member = std::get_if<double Params::*>(&field.member)) {
      params.** member = value;
    } else {
      const bool whole = std::isfinite(value) && std::floor(value) == value;
      if (!whole) {
        throw std::invalid_argument(std::string(Params::kAlgorithm) + ": " + std::string(name) +
                                    " must be an integer, got " + format_number(value));
      }
      if (std::abs(value) > kMaxIntegerParameter) {
        throw std::invalid_argument(std::string(Params::kAlgorithm) + ": " + std::string(name) +
                                    " = " + format_number(value) + " is beyond the limit of " +
                                    format_number(kMaxIntegerParameter) +
                                    " (sizes beyond it would exhaust memory)");
      }
      params.*std::get<int Params::*>(field.member) = static_cast<int>(value);
    }
    return;
  }
  throw std::invalid_argument(std::string(Params::kAlgorithm) + ": unknown parameter '" +
                              std::string(name) +
                              "'; valid parameters: " + parameter_names(params));
}

/// Defaults overridden by `overrides`, then validated (throws std::invalid_argument).
template <class Params>
Params parameters_from_map(const ParameterMap& overrides) {
  Params params;
  for (const auto& [name, value] : overrides) set_parameter(params, name, value);
  if (const std::string error = params.validate(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  return params;
}

/// Helpers for validate(): empty when fine, else "<ALG>: <name> must be <what>, got <value>".
inline std::string check_range(std::string_view algorithm, std::string_view name, double value,
                               double low, double high) {
  if (value >= low && value <= high) return {};
  return std::string(algorithm) + ": " + std::string(name) + " must be in [" + format_number(low) +
         ", " + format_number(high) + "], got " + format_number(value);
}
inline std::string check_at_least(std::string_view algorithm, std::string_view name, double value,
                                  double low) {
  if (value >= low && std::isfinite(value)) return {};
  return std::string(algorithm) + ": " + std::string(name) +
         " must be finite and >= " + format_number(low) + ", got " + format_number(value);
}
inline std::string check_positive(std::string_view algorithm, std::string_view name, double value) {
  if (value > 0.0 && std::isfinite(value)) return {};
  return std::string(algorithm) + ": " + std::string(name) + " must be positive and finite, got " +
         format_number(value);
}

}  // namespace insid::opt
