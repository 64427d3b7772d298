// Small helpers shared by the insid subcommands.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "bench/cluster.h"
#include "cli/progress.h"
#include "identification/grade.h"
#include "model/sensor_errors.h"

namespace insid::cli {

// Validators for numeric options (CLI11 checks the text before converting it; a failed check
// exits with "--option: <why>" naming the value). Limits are stated in the messages.

/// A whole number in [low, high] ("-1" for an option that counts is refused, not wrapped).
CLI::Validator whole_in(long long low, long long high);
/// A finite number in [low, high] (CLI::Range lets NaN through).
CLI::Validator number_in(double low, double high);
/// A seed: digits only, at most 2^64 - 1 (no sign, no wrap-around, no fraction).
CLI::Validator seed_value();
/// A finite number of seconds in (0, high].
CLI::Validator positive_seconds(double high);

/// Largest seed count of a campaign or sweep (each seed is a run file per algorithm).
inline constexpr long long kMaxSeeds = 100000;
/// Longest simulated flight (s): a day at 100 Hz is 8.6 million IMU rows, ~0.6 GB in memory.
inline constexpr double kMaxFlightS = 86400.0;
/// Most threads.
inline constexpr long long kMaxThreads = 4096;
/// Longest fitness window (s) for --window-s (a day of flight; longer = one run anyway).
inline constexpr double kMaxWindowS = 1e9;
/// --window-s help, shared by navigate, identify and diagnose.
inline constexpr const char* kWindowHelp =
    "windowed fitness: restart the INS from the GNSS position and velocity every W seconds "
    "after the navigation start, attitude carried on, Eq. 15 summed over the windows (0 = one "
    "pure-INS run over the whole flight, the paper's; W must be at least one GNSS period)";
/// identify's and diagnose's: the same, with the default that depends on the grade.
inline constexpr const char* kWindowWithDefaultHelp =
    "windowed fitness: restart the INS from the GNSS position and velocity every W seconds "
    "after the navigation start, attitude carried on, Eq. 15 summed over the windows (0 = one "
    "pure-INS run over the whole flight, the paper's; W must be at least one GNSS period). "
    "Default: 10 s when the grade is mems (results/window/README.md), else 0";

/// Parse "NAME=VALUE" items (catalogue names, SI values). `option` names the flag in errors.
std::map<std::string, double> parse_effect_assignments(const std::vector<std::string>& items,
                                                       const std::string& option);

/// Where and how a campaign command (bench, sweep) runs: --out, --threads, --force, --force-new,
/// --shard and the verbosity flags, declared once with one wording by add_campaign_run_options.
struct CampaignRunArgs {
  std::string out;
  int threads = 0;
  bool force = false;
  bool force_new = false;
  std::string shard;
  Verbosity verbosity = Verbosity::kNormal;
};

/// Declares the CampaignRunArgs options on `cmd` (--out is required).
void add_campaign_run_options(CLI::App* cmd, CampaignRunArgs* args);

/// The runner's options from `args`; progress goes through `printer` (its prefix names the
/// command). `shard` is parsed here (a bad one throws std::invalid_argument naming it).
campaign::RunOptions campaign_run_options(const CampaignRunArgs& args, campaign::Cluster* cluster,
                                          const std::shared_ptr<ProgressPrinter>& printer);

/// A campaign command's closing line on stderr: "<command>: <what>N new runs<split>, K already
/// done, of T; W s", then "; <done>\n" when the campaign is complete, else what is missing and
/// how to continue (rerun, or the other shards then `insid merge out_dir`). <split> is
/// " (shard i/N)" or " on N MPI ranks (9 + 8 + 1)", empty for a plain run.
void print_campaign_closing(const std::string& command, const std::string& what,
                            const campaign::RunOptions& options,
                            const campaign::CampaignOutcome& outcome, const std::string& done);

/// Prints a campaign's progress (bench, sweep) through `printer` (its prefix names the
/// command): scenario preparation, the optimum, and the status line of finished runs with
/// elapsed time and ETA.
campaign::ProgressCallback campaign_progress_printer(std::shared_ptr<ProgressPrinter> printer);

/// What a command that writes single output files (navigate, identify, diagnose) may replace:
/// never one of `inputs` (the files it reads), and an existing file insid did not write only
/// with `force` (the command's --force; base/output_dir.h, file_owner).
struct OutputGuard {
  std::vector<std::filesystem::path> inputs;
  bool force = false;
};

/// Adds --force to a command that writes output files ("replace output files insid did not
/// write").
void add_output_force_flag(CLI::App* cmd, bool* force);

/// The files of the dataset in `data_dir` that exist (its meta.json, CSV files and the other
/// entries insid keeps there): the inputs of a command given --data.
std::vector<std::filesystem::path> dataset_input_files(const std::string& data_dir);

/// Throws when `path` may not be written under `guard` (checked before the work; nothing for
/// "" or "-", stdout).
void check_output_file(const std::string& path, const OutputGuard& guard);

/// The dataset's plausibility (data/plausibility.h) for a command that reads one: each finding
/// printed as "<command>: implausible data: ..." on stderr (even with --quiet: it is about the
/// user's data, like an import's notes); a refusal thrown as std::runtime_error. Returns the
/// report's JSON for the command's result.
nlohmann::json check_dataset_plausibility(const Dataset& dataset, const std::string& command);

/// Prints the findings of a result's "plausibility" block (as check_dataset_plausibility).
void print_plausibility(const nlohmann::json& plausibility, const std::string& command);

/// Throws a UsageError (exit 2) when two of a command's outputs, (option, path) pairs, name the
/// same file (the same path, or an existing file and a link to it): the second write would
/// replace the first. "" and "-" (stdout) are skipped.
void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& outputs);

/// Writes an output file atomically under `guard` (a device or FIFO is written to).
void write_output_file(const std::string& path, const std::string& text, const OutputGuard& guard);

/// Write JSON to `path` atomically under `guard`, or to stdout when path is empty or "-".
void write_json_output(const std::string& path, const nlohmann::json& j, const OutputGuard& guard);

}  // namespace insid::cli
