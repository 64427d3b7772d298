// insid bench: run (or resume) a campaign of identification runs.
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "bench/cluster.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "core/json_reader.h"

namespace insid::cli {
namespace {

struct BenchArgs {
  std::string preset;
  std::string config_path;
  std::string out;
  int seeds = 0;
  int threads = 0;
  bool force_new = false;
  bool force = false;
  int max_new_runs = 0;
  double flight_s = 0.0;
  std::string shard;
  Verbosity verbosity = Verbosity::kNormal;
};

void run_bench(const BenchArgs& args) {
  // Joined first, so that every rank of an MPI launch sees the same errors below.
  const std::unique_ptr<campaign::Cluster> cluster = campaign::join_mpi_launch();
  if (args.preset.empty() == args.config_path.empty())
    throw UsageError("give exactly one of --preset and --config");
  campaign::CampaignConfig config;
  if (!args.preset.empty()) {
    config = campaign::preset_campaign(args.preset);
  } else {
    nlohmann::json j;
    try {
      j = read_json_file(args.config_path, "--config " + args.config_path);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(e.what());
    }
    config = campaign::parse_campaign(j, args.config_path);
  }
  if (args.seeds > 0) config.seeds = campaign::seed_range(args.seeds);
  if (args.flight_s > 0)
    for (auto& s : config.scenarios) s.flight_s = args.flight_s;
  campaign::RunOptions options;
  options.out_dir = args.out;
  options.threads = args.threads;
  options.force_new = args.force_new;
  options.into_foreign_directory = args.force;
  options.max_new_runs = args.max_new_runs;
  if (!args.shard.empty()) options.shard = campaign::Shard::parse(args.shard);
  options.cluster = cluster.get();
  const auto printer = std::make_shared<ProgressPrinter>("insid bench", args.verbosity);
  options.progress = campaign_progress_printer(printer);
  options.quiet = printer->quiet();
  const campaign::CampaignOutcome outcome = campaign::run_campaign(config, options);
  printer->finish();
  if (!outcome.writes_results) return;  // MPI rank 0 reports for the launch
  if (printer->quiet()) return;
  std::cerr << "insid bench: " << outcome.new_runs << " new runs"
            << cli::split_description(options, outcome) << ", " << outcome.skipped_runs
            << " already done, of " << outcome.total_runs << "; "
            << static_cast<long>(std::lround(outcome.wall_s)) << " s";
  if (outcome.complete)
    std::cerr << "; summary written to " + args.out + "/summary.json\n";
  else
    std::cerr << cli::incomplete_message(options, outcome);
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench",
      "Run (or resume) a campaign: scenarios x algorithms x seeds of identification runs, "
      "written as JSON under --out (results/README.md), with summary statistics.");
  cmd->add_option("--preset", args->preset,
                  "campaign preset: paper-fig9 | quick | paper-plus-baselines");
  cmd->add_option("--config", args->config_path, "campaign JSON file (results/README.md)");
  cmd->add_option("--out", args->out, "results directory")->required();
  cmd->add_option("--seeds", args->seeds, "number of seeds (1..N), overriding the config")
      ->check(whole_in(1, kMaxSeeds));
  cmd->add_option("--threads", args->threads, "threads (0 = all cores)")
      ->capture_default_str()
      ->check(whole_in(0, kMaxThreads));
  cmd->add_option("--flight-s", args->flight_s,
                  "override every simulated scenario's flight length after alignment (s)")
      ->check(positive_seconds(kMaxFlightS));
  cmd->add_flag("--force", args->force,
                "write into a --out directory that holds other files than a campaign's (they are "
                "kept)");
  cmd->add_flag("--force-new", args->force_new,
                "discard results of a different campaign found in --out");
  cmd->add_option("--max-new-runs", args->max_new_runs,
                  "stop after this many new runs (the rest on the next invocation)")
      ->check(whole_in(1, 1000000000));
  cmd->add_option("--shard", args->shard,
                  "do only slice i of N of the runs (i/N, 1 <= i <= N; for batch-scheduler "
                  "arrays): runs whose position in the run list modulo N is i-1");
  add_verbosity_flags(cmd, args->verbosity);
  cmd->callback([args] { run_bench(*args); });
}

}  // namespace insid::cli
