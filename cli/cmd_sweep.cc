// insid sweep: tune optimizer parameters (PIO/DVPIO R, d, premature threshold) over seeds.
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bench/cluster.h"
#include "bench/sweep.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::cli {
namespace {

struct SweepArgs {
  std::string algorithm = "dvpio";
  std::vector<std::string> grid;
  int random = 0;
  int seeds = 11;
  std::string preset = "paper";
  std::string data_dir;
  double flight_s = 0.0;
  std::string grade;
  int iterations = 40;
  std::int64_t evaluations = 0;
  std::string alignment = "per-candidate";
  std::string initial_attitude;  // empty: gyrocompass (the key not written)
  double heading_deg = std::numeric_limits<double>::quiet_NaN();
  double window_s = 0.0;
  std::string estimation_grade;  // empty: the catalogue's sigmas (the key not written)
  CampaignRunArgs run;
};

void run(const SweepArgs& args) {
  const std::unique_ptr<campaign::Cluster> cluster = campaign::join_mpi_launch("insid sweep");
  campaign::SweepConfig sweep;
  sweep.algorithm = args.algorithm;
  for (const std::string& g : args.grid)
    sweep.axes.push_back(parse_option("--grid", [&] { return campaign::SweepAxis::parse(g); }));
  sweep.random_settings = args.random;
  sweep.seeds = campaign::seed_range(args.seeds);
  if (!args.data_dir.empty()) {
    sweep.scenario.name = "data";
    sweep.scenario.data_dir = args.data_dir;
  } else {
    sweep.scenario.name = args.preset;
    sweep.scenario.preset = args.preset;
  }
  if (args.flight_s > 0) sweep.scenario.flight_s = args.flight_s;
  if (!args.grade.empty()) sweep.scenario.grade = args.grade;
  // Names the command line gave, checked now (usage errors, exit 2), not deep in the campaign.
  if (args.data_dir.empty())
    parse_option("--preset", [&] { return scenarios::preset_scenario(args.preset); });
  if (!args.grade.empty())
    parse_option("--grade", [&] { return scenarios::noise_grade(args.grade); });
  sweep.max_iterations = args.iterations;
  sweep.max_evaluations = args.evaluations;
  sweep.alignment =
      parse_option("--alignment", [&] { return alignment_mode_from_string(args.alignment); });
  if (!args.initial_attitude.empty())
    sweep.initial_attitude = initial_attitude_mode_from_string(args.initial_attitude);
  if (!std::isnan(args.heading_deg)) sweep.heading_deg = args.heading_deg;
  sweep.window_s = args.window_s;
  if (!args.estimation_grade.empty()) sweep.estimation_grade = args.estimation_grade;
  // Labelled "insid sweep" (the campaign runner behind it is bench's).
  const auto printer = std::make_shared<ProgressPrinter>("insid sweep", args.run.verbosity);
  // The sweep is the command line's: what its check refuses is a usage error (exit 2).
  if (const std::string why = sweep.validate(); !why.empty()) throw UsageError(why);
  const campaign::RunOptions options = campaign_run_options(args.run, cluster.get(), printer);
  const auto outcome = campaign::run_sweep(sweep, options);
  printer->finish();
  if (!outcome.writes_results) return;  // MPI rank 0 reports for the launch
  if (printer->quiet()) return;
  print_campaign_closing("insid sweep",
                         std::to_string(campaign::sweep_settings(sweep).size()) + " settings x " +
                             std::to_string(sweep.seeds.size()) + " seeds; ",
                         options, outcome, "wrote " + args.run.out + "/sweep.json and sweep.csv");
}

}  // namespace

void add_sweep_command(CLI::App& app) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* cmd = app.add_subcommand(
      "sweep",
      "Tune an optimizer's parameters: every setting of a grid (or random settings) over the "
      "same seeds; per-setting median/IQR of final fitness and parameter error, best settings "
      "with bootstrap confidence intervals (sweep.json, sweep.csv).");
  cmd->add_option("--algo", args->algorithm, "algorithm (pio, dvpio, pso, ga, ...)")
      ->capture_default_str();
  cmd->add_option("--grid", args->grid,
                  "KEY=LO:HI:N (N linear values) or KEY=V1,V2,...; keys are the algorithm's "
                  "parameters (d0 = d_initial); a _sigma suffix gives distances in sigma units "
                  "(d0_sigma=0.01:0.2:5, dist_threshold_sigma=...)")
      ->required();
  cmd->add_option("--random", args->random,
                  "draw this many random settings in the grid ranges instead of the full grid")
      ->check(whole_in(1, kMaxSeeds));
  cmd->add_option("--seeds", args->seeds, "seeds per setting (1..N)")
      ->capture_default_str()
      ->check(whole_in(1, kMaxSeeds));
  CLI::Option* preset = cmd->add_option("--preset", args->preset, "scenario preset to simulate")
                            ->capture_default_str();
  CLI::Option* data =
      cmd->add_option("--data", args->data_dir, "use this dataset instead of a preset");
  cmd->add_option("--flight-s", args->flight_s, "flight length after alignment (s) for the preset")
      ->check(positive_seconds(kMaxFlightS))
      ->excludes(data);
  cmd->add_option("--grade", args->grade, "noise grade for the preset (nav, mems, paper, none)")
      ->excludes(data);
  preset->excludes(data);  // beside --data a preset would be silently ignored: a usage error
  cmd->add_option("--iterations", args->iterations, "iteration budget")
      ->capture_default_str()
      ->check(whole_in(0, 10000000));
  cmd->add_option("--evaluations", args->evaluations, "evaluation budget (0 = none)")
      ->check(whole_in(0, 1000000000));
  cmd->add_option("--alignment", args->alignment, "per-candidate | fixed")->capture_default_str();
  cmd->add_option("--initial-attitude", args->initial_attitude,
                  "gyrocompass | level+heading | given | truth (the campaign key "
                  "initial_attitude; default: gyrocompass, as before)");
  cmd->add_option("--heading-deg", args->heading_deg,
                  "level+heading: the heading at the start (deg); default: the GNSS course");
  cmd->add_option("--window-s", args->window_s,
                  "windowed fitness: INS restarted from GNSS every W s (0 = one run)")
      ->capture_default_str();
  cmd->add_option("--estimation-grade", args->estimation_grade,
                  "nav | tactical | mems: the sigmas and default parameters of the estimation, as "
                  "identify's --grade (the campaign key estimation_grade; --grade is the "
                  "simulated noise); default: the catalogue's, as before");
  add_campaign_run_options(cmd, &args->run);
  cmd->callback([args] { run(*args); });
}

}  // namespace insid::cli
