#include "cli/cli_util.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <system_error>

#include "cli/commands.h"
#include "data/dataset.h"
#include "data/plausibility.h"
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
      throw std::invalid_argument(option + " " + name +
                                  ": expected a finite number (SI units), got '" + text + "'");
    out[name] = value;
  }
  return out;
}

campaign::ProgressCallback campaign_progress_printer(std::shared_ptr<ProgressPrinter> printer) {
  using Kind = campaign::ProgressEvent::Kind;
  return [printer](const campaign::ProgressEvent& e) {
    const auto whole = [](double s) { return std::to_string(std::lround(s)); };
    switch (e.kind) {
      case Kind::kRemovedTemporaries:
        printer->note("removed " + std::to_string(e.count) +
                      " temporary file(s) left by an interrupted run in " + e.path);
        break;
      case Kind::kRedoingDamagedRun:
        printer->note("redoing a damaged run file: " + e.detail);
        break;
      case Kind::kPreparingScenario:
        printer->note("preparing scenario " + e.scenario);
        break;
      case Kind::kFindingOptimum:
        printer->note("finding the data's own optimum of " + e.scenario);
        break;
      case Kind::kWaitingForOptimum:
        printer->note("waiting for another rank to write " + e.path);
        break;
      case Kind::kRunFinished:
        if (!e.mpi_rank)
          printer->status("runs " + std::to_string(e.runs_present) + "/" +
                          std::to_string(e.runs_total) + " (" + e.scenario + " " + e.algorithm +
                          " seed " + std::to_string(e.seed) + "), elapsed " + whole(e.elapsed_s) +
                          " s, ETA " + whole(e.eta_s) + " s");
        else  // rank 0 sees only its own runs
          printer->status("rank 0 finished " + std::to_string(e.new_runs) + " runs (" + e.scenario +
                          " " + e.algorithm + " seed " + std::to_string(e.seed) + "), elapsed " +
                          whole(e.elapsed_s) + " s");
        break;
      case Kind::kRunsEnded:
        printer->finish();
        break;
    }
  };
}

void add_output_force_flag(CLI::App* cmd, bool* force) {
  cmd->add_flag("--force", *force,
                "replace existing output files that insid did not write (never the command's "
                "own input files)");
}

std::vector<std::filesystem::path> dataset_input_files(const std::string& data_dir) {
  std::vector<std::filesystem::path> files;
  for (const std::string& name : dataset_directory_entries()) {
    const std::filesystem::path p = std::filesystem::path(data_dir) / name;
    std::error_code ec;
    if (std::filesystem::exists(p, ec)) files.push_back(p);
  }
  return files;
}

void check_output_file(const std::string& path, const OutputGuard& guard) {
  if (path.empty() || path == "-") return;
  refuse_replacing_inputs(path, guard.inputs, /*whole_directory=*/false);
  WriteOptions options;
  options.replace_foreign = guard.force;
  check_file_writable(path, options);
}

nlohmann::json check_dataset_plausibility(const Dataset& dataset, const std::string& command) {
  const PlausibilityReport report = check_plausibility(dataset);
  for (const PlausibilityFinding& f : report.findings)
    std::cerr << command << ": " << f.text() << "\n";
  if (report.refused()) throw std::runtime_error("the data cannot be right (above)");
  return report.to_json();
}

void print_plausibility(const nlohmann::json& plausibility, const std::string& command) {
  if (!plausibility.is_object()) return;
  for (const nlohmann::json& f : plausibility.value("findings", nlohmann::json::array()))
    std::cerr << command << ": implausible data: " << f.value("quantity", "") << ": expected "
              << f.value("expected", "") << ", found " << f.value("found", "") << ": "
              << f.value("likely_cause", "") << "\n";
}

void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  namespace fs = std::filesystem;
  auto same = [](const std::string& a, const std::string& b) {
    std::error_code ec;
    if (fs::weakly_canonical(fs::absolute(a), ec) == fs::weakly_canonical(fs::absolute(b), ec))
      return true;
    std::error_code eq;
    return fs::exists(a, eq) && fs::exists(b, eq) && fs::equivalent(a, b, eq);
  };
  for (std::size_t i = 0; i < outputs.size(); ++i)
    for (std::size_t j = i + 1; j < outputs.size(); ++j) {
      const auto& [option_a, path_a] = outputs[i];
      const auto& [option_b, path_b] = outputs[j];
      if (path_a.empty() || path_a == "-" || path_b.empty() || path_b == "-") continue;
      if (same(path_a, path_b))
        throw UsageError(option_a + " '" + path_a + "' and " + option_b + " '" + path_b +
                         "' are the same file: one output would replace the other; give two "
                         "different paths");
    }
}

void write_output_file(const std::string& path, const std::string& text, const OutputGuard& guard) {
  refuse_replacing_inputs(path, guard.inputs, /*whole_directory=*/false);
  WriteOptions options;
  options.replace_foreign = guard.force;
  write_file_atomic(path, text, options);
}

void write_json_output(const std::string& path, const nlohmann::json& j, const OutputGuard& guard) {
  const std::string text = j.dump(2) + "\n";
  if (path.empty() || path == "-") {
    std::cout << text;
    return;
  }
  write_output_file(path, text, guard);
}

namespace {

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

}  // namespace

void add_campaign_run_options(CLI::App* cmd, CampaignRunArgs* args) {
  cmd->add_option("--out", args->out, "results directory")->required();
  cmd->add_option("--threads", args->threads, "threads (0 = all cores)")
      ->capture_default_str()
      ->check(whole_in(0, kMaxThreads));
  cmd->add_flag("--force", args->force,
                "write into a --out directory that holds other files than a campaign's (they are "
                "kept)");
  cmd->add_flag("--force-new", args->force_new,
                "discard results of a different campaign found in --out");
  cmd->add_option("--shard", args->shard,
                  "do only slice i of N of the runs (i/N, 1 <= i <= N; for batch-scheduler "
                  "arrays): runs whose position in the run list modulo N is i-1");
  add_verbosity_flags(cmd, args->verbosity);
}

campaign::RunOptions campaign_run_options(const CampaignRunArgs& args, campaign::Cluster* cluster,
                                          const std::shared_ptr<ProgressPrinter>& printer) {
  campaign::RunOptions options;
  options.out_dir = args.out;
  options.threads = args.threads;
  options.force_new = args.force_new;
  options.into_foreign_directory = args.force;
  if (!args.shard.empty())
    options.shard = parse_option("--shard", [&] { return campaign::Shard::parse(args.shard); });
  // The checks of the options alone (--out '', --force-new with --shard): usage errors.
  if (const std::string why = options.validate(); !why.empty()) throw UsageError(why);
  options.cluster = cluster;
  options.progress = campaign_progress_printer(printer);
  options.quiet = printer->quiet();
  return options;
}

void print_campaign_closing(const std::string& command, const std::string& what,
                            const campaign::RunOptions& options,
                            const campaign::CampaignOutcome& outcome, const std::string& done) {
  std::cerr << command << ": " << what << outcome.new_runs << " new runs"
            << split_description(options, outcome) << ", " << outcome.skipped_runs
            << " already done, of " << outcome.total_runs << "; "
            << static_cast<long>(std::lround(outcome.wall_s)) << " s";
  if (outcome.complete) {
    std::cerr << "; " << done << "\n";
    return;
  }
  std::cerr << "; incomplete: " << outcome.missing_report << "\nRerun the same command to continue"
            << (options.shard.active()
                    ? " (or run the other shards, then insid merge " + options.out_dir + ")"
                    : "")
            << ".\n";
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
          return "value " + text + " s is outside the allowed (0, " + opt::format_number(high) +
                 "] s";
        return "";
      },
      "SECONDS");
}

}  // namespace insid::cli
