// Small helpers shared by the insid subcommands.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/sensor_errors.h"

namespace insid::cli {

/// Parse "NAME=VALUE" items (catalogue names, SI values). `option` names the flag in errors.
std::map<std::string, double> parse_effect_assignments(const std::vector<std::string>& items,
                                                       const std::string& option);

/// "9 + 8 + 1": counts as a sum (runs per MPI rank).
std::string sum_terms(const std::vector<int>& counts);

/// Write JSON to `path` atomically, or to stdout when path is empty or "-".
void write_json_output(const std::string& path, const nlohmann::json& j);

}  // namespace insid::cli
