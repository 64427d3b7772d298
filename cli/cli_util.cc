#include "cli/cli_util.h"

#include <charconv>
#include <cstdint>
#include <system_error>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <stdexcept>

#include "core/dataset.h"
#include "optimizers/parameters.h"

namespace insid::cli {

std::map<std::string, double> parse_effect_assignments(const std::vector<std::string>& items,
                                                       const std::string& option) {
  std::map<std::string, double> out;
  for (const std::string& item : items) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size())
      throw std::invalid_argument(option + ": expected NAME=VALUE, got '" + item + "'");
    const std::string name = item.substr(0, eq);
    const std::string text = item.substr(eq + 1);
    effect_info(name);  // throws with the list of valid names
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(value))
      throw std::invalid_argument(option + " " + name + ": expected a finite number (SI units), got '" +
                                  text + "'");
    out[name] = value;
  }
  return out;
}

campaign::ProgressCallback campaign_progress_printer() {
  using Kind = campaign::ProgressEvent::Kind;
  return [](const campaign::ProgressEvent& e) {
    switch (e.kind) {
      case Kind::kRemovedTemporaries:
        std::cerr << "insid: removed " << e.count
                  << " temporary file(s) left by an interrupted run in " << e.path << "\n";
        break;
      case Kind::kRedoingDamagedRun:
        std::cerr << "insid bench: redoing a damaged run file: " << e.detail << "\n";
        break;
      case Kind::kPreparingScenario:
        std::cerr << "insid bench: preparing scenario " << e.scenario << "\n";
        break;
      case Kind::kFindingOptimum:
        std::cerr << "insid bench: finding the data's own optimum of " << e.scenario << "\n";
        break;
      case Kind::kWaitingForOptimum:
        std::cerr << "insid bench: waiting for another rank to write "
                  << std::filesystem::path(e.path) << "\n";
        break;
      case Kind::kRunFinished:
        std::cerr << std::fixed << std::setprecision(0);
        if (!e.mpi_rank)
          std::cerr << "\rinsid bench: runs " << e.runs_present << "/" << e.runs_total << " ("
                    << e.scenario << " " << e.algorithm << " seed " << e.seed << "), elapsed "
                    << e.elapsed_s << " s, ETA " << e.eta_s << " s   ";
        else  // rank 0 sees only its own runs
          std::cerr << "\rinsid bench: rank 0 finished " << e.new_runs << " runs (" << e.scenario
                    << " " << e.algorithm << " seed " << e.seed << "), elapsed " << e.elapsed_s
                    << " s   ";
        std::cerr << std::defaultfloat << std::flush;
        break;
      case Kind::kRunsEnded:
        std::cerr << "\n";
        break;
    }
  };
}

void write_json_output(const std::string& path, const nlohmann::json& j) {
  const std::string text = j.dump(2) + "\n";
  if (path.empty() || path == "-") {
    std::cout << text;
    return;
  }
  write_file_atomic(path, text);
}

std::string split_description(const campaign::RunOptions& options,
                              const campaign::CampaignOutcome& outcome) {
  std::string text;
  if (options.shard.active()) text += " (shard " + options.shard.to_string() + ")";
  if (options.cluster != nullptr) {
    std::string per_rank;
    for (int n : outcome.new_runs_per_rank)
      per_rank += (per_rank.empty() ? "" : " + ") + std::to_string(n);
    text += " on " + std::to_string(options.cluster->size()) + " MPI ranks (" + per_rank + ")";
  }
  return text;
}

std::string incomplete_message(const campaign::RunOptions& options,
                               const campaign::CampaignOutcome& outcome) {
  return "; incomplete: " + outcome.missing_report + "\nRerun the same command to continue" +
         (options.shard.active()
              ? " (or run the other shards, then insid merge " + options.out_dir + ")"
              : "") +
         ".\n";
}

CLI::Validator whole_in(long long low, long long high) {
  return CLI::Validator(
      [low, high](std::string& text) -> std::string {
        long long value = 0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (ec != std::errc() || ptr != end)
          return "expected a whole number in [" + std::to_string(low) + ", " +
                 std::to_string(high) + "], got '" + text + "'";
        if (value < low || value > high)
          return "value " + text + " is outside the allowed [" + std::to_string(low) + ", " +
                 std::to_string(high) + "]";
        return "";
      },
      "INT in [" + std::to_string(low) + ", " + std::to_string(high) + "]");
}

CLI::Validator seed_value() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t value = 0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (text.empty() || text.front() == '-' || text.front() == '+' || ec != std::errc() ||
            ptr != end)
          return "expected a seed, a whole number in [0, 18446744073709551615], got '" + text + "'";
        return "";
      },
      "SEED");
}

CLI::Validator number_in(double low, double high) {
  return CLI::Validator(
      [low, high](std::string& text) -> std::string {
        double value = 0.0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (ec != std::errc() || ptr != end || !std::isfinite(value))
          return "expected a finite number, got '" + text + "'";
        if (!(value >= low && value <= high))
          return "value " + text + " is outside the allowed [" + opt::format_number(low) + ", " +
                 opt::format_number(high) + "]";
        return "";
      },
      "NUMBER in [" + opt::format_number(low) + ", " + opt::format_number(high) + "]");
}

CLI::Validator positive_seconds(double high) {
  return CLI::Validator(
      [high](std::string& text) -> std::string {
        double value = 0.0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (ec != std::errc() || ptr != end || !std::isfinite(value))
          return "expected a finite number of seconds, got '" + text + "'";
        if (!(value > 0.0 && value <= high))
          return "value " + text + " s is outside the allowed (0, " + opt::format_number(high) + "] s";
        return "";
      },
      "SECONDS");
}

}  // namespace insid::cli
