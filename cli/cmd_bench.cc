// insid bench: run (or resume) a campaign of identification runs.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>

#include "bench/campaign.h"
#include "bench/cluster.h"
#include "cli/cli_util.h"
#include "cli/commands.h"

namespace insid::cli {
namespace {

struct BenchArgs {
  std::string preset;
  std::string config_path;
  int seeds = 0;
  int max_new_runs = 0;
  double flight_s = 0.0;
  std::string round_log;
  std::string fitness;
  CampaignRunArgs run;
};

void run_bench(const BenchArgs& args) {
  // Joined first, so that every rank of an MPI launch sees the same errors below.
  const std::unique_ptr<campaign::Cluster> cluster = campaign::join_mpi_launch("insid bench");
  if (args.preset.empty() == args.config_path.empty())
    throw UsageError("give exactly one of --preset and --config");
  campaign::CampaignConfig config;
  if (!args.preset.empty()) {
    config = parse_option("--preset", [&] { return campaign::preset_campaign(args.preset); });
  } else {
    config = campaign::read_campaign_file(args.config_path);
  }
  if (args.seeds > 0) config.seeds = campaign::seed_range(args.seeds);
  if (!args.fitness.empty())
    config.search_fitness =
        parse_option("--fitness", [&] { return kSearchFitnessNames.value(args.fitness); });
  if (args.flight_s > 0)
    for (auto& s : config.scenarios) s.flight_s = args.flight_s;
  const auto printer = std::make_shared<ProgressPrinter>("insid bench", args.run.verbosity);
  campaign::RunOptions options = campaign_run_options(args.run, cluster.get(), printer);
  options.max_new_runs = args.max_new_runs;
  if (!args.config_path.empty()) options.inputs.emplace_back(args.config_path);
  // One JSON line per lock-step round (scripts/perf_rounds.py reads them); a new file only, so
  // that a mistyped name never replaces one of the user's files.
  std::ofstream round_log;
  std::size_t rounds_logged = 0;
  if (!args.round_log.empty()) {
    if (cluster != nullptr)
      throw UsageError("--round-log: not with an MPI launch (each rank has its own rounds)");
    std::error_code ec;
    if (std::filesystem::exists(args.round_log, ec) || ec)
      throw UsageError("--round-log " + args.round_log +
                       ": the file exists; give a new file name (it is never overwritten)");
    round_log.open(args.round_log);
    if (!round_log)
      throw std::runtime_error("--round-log " + args.round_log + ": cannot create the file");
    round_log << std::setprecision(9);
    options.round_finished = [&round_log, &rounds_logged](const campaign::RoundRecord& r) {
      ++rounds_logged;
      round_log << R"({"wave": )" << r.wave << R"(, "wave_runs": )" << r.wave_runs
                << R"(, "candidates": )" << r.candidates << R"(, "scored": )" << r.scored
                << R"(, "scoring_s": )" << r.scoring_s << R"(, "round_s": )" << r.round_s << "}\n";
    };
  }
  campaign::CampaignOutcome outcome;
  try {
    outcome = campaign::run_campaign(config, options);
  } catch (...) {
    // A campaign refused before its first round leaves no empty log behind.
    if (round_log.is_open() && rounds_logged == 0) {
      round_log.close();
      std::error_code ec;
      std::filesystem::remove(args.round_log, ec);
    }
    throw;
  }
  printer->finish();
  if (round_log.is_open()) {
    round_log.close();
    if (!round_log) throw std::runtime_error("--round-log " + args.round_log + ": write failed");
  }
  if (!outcome.writes_results) return;  // MPI rank 0 reports for the launch
  if (printer->quiet()) return;
  print_campaign_closing("insid bench", "", options, outcome,
                         "summary written to " + args.run.out + "/summary.json");
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
  cmd->add_option("--seeds", args->seeds, "number of seeds (1..N), overriding the config")
      ->check(whole_in(1, kMaxSeeds));
  cmd->add_option("--flight-s", args->flight_s,
                  "override every simulated scenario's flight length after alignment (s)")
      ->check(positive_seconds(kMaxFlightS));
  cmd->add_option(
      "--fitness", args->fitness,
      "what steers the optimizers, overriding the config: fast (a second-order model "
      "of the residuals, used when its check against the exact kernel passes; the "
      "default) | exact (the exact kernel for every candidate). The exact kernel scores "
      "every reported number either way (docs/design.md sec. 12)");
  cmd->add_option("--max-new-runs", args->max_new_runs,
                  "stop after this many new runs (the rest on the next invocation)")
      ->check(whole_in(1, 1000000000));
  cmd->add_option("--round-log", args->round_log,
                  "write one JSON line per lock-step round to this new file (candidates, "
                  "scoring and round wall time; for scripts/perf_rounds.py)");
  add_campaign_run_options(cmd, &args->run);
  cmd->callback([args] { run_bench(*args); });
}

}  // namespace insid::cli
