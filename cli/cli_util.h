// Small helpers shared by the insid subcommands.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "bench/cluster.h"
#include "core/sensor_errors.h"

namespace insid::cli {

/// Parse "NAME=VALUE" items (catalogue names, SI values). `option` names the flag in errors.
std::map<std::string, double> parse_effect_assignments(const std::vector<std::string>& items,
                                                       const std::string& option);

/// How a campaign's new runs were split, for its closing line: " (shard i/N)" or
/// " on N MPI ranks (9 + 8 + 1)"; empty for a plain run.
std::string split_description(const campaign::RunOptions& options,
                              const campaign::CampaignOutcome& outcome);

/// The end of an incomplete campaign's closing line: "; incomplete: <missing runs>" and how to
/// continue (rerun, or the other shards then `insid merge out_dir`).
std::string incomplete_message(const campaign::RunOptions& options,
                               const campaign::CampaignOutcome& outcome);

/// Write JSON to `path` atomically, or to stdout when path is empty or "-".
void write_json_output(const std::string& path, const nlohmann::json& j);

}  // namespace insid::cli
