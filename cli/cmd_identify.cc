// insid identify: find the sensor errors of a dataset with GA / PSO / PIO / DVPIO or a reference
// baseline (CMA-ES, DE, compass, LM, BOBYQA, Nelder-Mead, EKF-RTS).
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/initial_attitude_cli.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "identification/identify.h"
#include "identification/identify_run.h"
#include "nav/fitness.h"

namespace insid::cli {
namespace {

struct IdentifyArgs {
  std::string data_dir;
  std::string algorithm = "dvpio";
  std::vector<std::string> estimate;
  std::string grade = "auto";
  std::vector<std::string> params;
  std::uint64_t seed = 1;
  int iterations = 40;
  std::int64_t evaluations = 0;
  std::string alignment = "per-candidate";
  std::optional<double> window_s;  ///< absent: the grade's default (settle_grade_and_window)
  InitialAttitudeArgs initial_attitude;
  int threads = 0;
  bool no_reference = false;
  bool positions = false;
  int uncertainty_replicas = 100;
  bool fixed_box = false;
  int max_widenings = BoxWideningOptions{}.max_rounds;
  bool gyro_bias_at_rest = false;
  std::string fitness = "fast";
  std::string out;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;
};

// The command line's option for each field of IdentifySpec (its errors name the field).
std::string option_of(const std::string& field) {
  static const std::map<std::string, std::string> kOptions = {
      {"data_dir", "--data"},
      {"algorithm", "--algo"},
      {"estimate", "--estimate"},
      {"grade", "--grade"},
      {"params", "--param"},
      {"iterations", "--iterations"},
      {"evaluations", "--evaluations"},
      {"window_s", "--window-s"},
      {"threads", "--threads"},
      {"uncertainty_replicas", "--uncertainty-replicas"},
      {"initial_attitude", "--initial-attitude"},
      {"box_widening.max_rounds", "--max-widenings"},
      {"gyro_bias_at_rest", "--gyro-bias-at-rest"}};
  const auto it = kOptions.find(field);
  return it == kOptions.end() ? field : it->second;
}

// The spec's error as a usage error (exit 2) naming the command line's option where the spec
// named its own field ("uncertainty_replicas 5: ..." -> "--uncertainty-replicas 5: ...").
[[noreturn]] void throw_usage(const IdentifySpecError& e) {
  std::string what = e.what();
  if (what.rfind(e.field(), 0) == 0) what = option_of(e.field()) + what.substr(e.field().size());
  throw UsageError(what);
}

void run_identify(const IdentifyArgs& args) {
  // The output is checked before the work: never an input, a file of others only with --force.
  const OutputGuard guard{dataset_input_files(args.data_dir), args.force};
  check_output_file(args.out, guard);
  // The arguments as a spec (identification/identify.h); the pipeline is the library's.
  IdentifySpec spec;
  spec.data_dir = args.data_dir;
  spec.algorithm = args.algorithm;
  spec.estimate = args.estimate;
  spec.grade = args.grade;
  spec.params = args.params;
  spec.seed = args.seed;
  spec.iterations = args.iterations;
  spec.evaluations = args.evaluations;
  spec.alignment =
      parse_option("--alignment", [&] { return alignment_mode_from_string(args.alignment); });
  spec.window_s = args.window_s;
  spec.initial_attitude = initial_attitude_options(args.initial_attitude);
  spec.threads = args.threads;
  spec.reference_optimum = !args.no_reference;
  spec.record_positions = args.positions;
  spec.uncertainty_replicas = args.uncertainty_replicas;
  spec.box_widening.enabled = !args.fixed_box;
  spec.box_widening.max_rounds = args.max_widenings;
  spec.gyro_bias_at_rest = args.gyro_bias_at_rest;
  spec.search_fitness =
      parse_option("--fitness", [&] { return kSearchFitnessNames.value(args.fitness); });
  if (const std::optional<IdentifySpecError> problem = spec_problem(spec))
    throw_usage(*problem);  // before the dataset is read
  ProgressPrinter progress("insid identify", args.verbosity);
  IdentifyProgress reporting;
  reporting.note = [&progress](const std::string& text) { progress.note(text); };
  reporting.status = [&progress](const std::string& text) { progress.status(text); };
  reporting.finish = [&progress] { progress.finish(); };
  IdentifyReport report;
  try {
    report = identify(spec, reporting);
  } catch (const IdentifySpecError& e) {
    throw_usage(e);
  }
  print_plausibility(report.result["plausibility"], "insid identify");  // even with --quiet
  if (!progress.quiet()) std::cerr << report.tables;
  write_json_output(args.out, report.result, guard);
}

}  // namespace

void add_identify_command(CLI::App& app) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* cmd = app.add_subcommand(
      "identify",
      "Identify sensor errors of a dataset with an optimizer (Eq. 15 fitness, one full "
      "alignment + pure-INS run per candidate); writes a result JSON.");
  cmd->add_option("--data", args->data_dir, "dataset directory (insid-dataset/1)")->required();
  cmd->add_option(
         "--algo", args->algorithm,
         "ga | pso | pio | dvpio (the paper's), or a reference baseline: cmaes | de | "
         "compass | lm | bobyqa | neldermead | ekf-rts (optimizers/README.md), or external:CMD, a "
         "program speaking the JSON-lines protocol of optimizers/README.md (e.g. "
         "\"external:/usr/bin/python3 scripts/external_random_search.py\")")
      ->capture_default_str();
  cmd->add_option("--estimate", args->estimate,
                  "NAME[:SIGMA[:LO:HI]] (SIGMA in SI, box in sigma units; without SIGMA the "
                  "grade's sigma); default: the paper's "
                  "four (accel_bias_x accel_bias_y gyro_bias_x gyro_bias_y), [-4, 4] sigma");
  cmd->add_option("--grade", args->grade,
                  "sensor grade auto | nav | tactical | mems: the search unit (sigma) of every "
                  "--estimate NAME without SIGMA and the default parameters (nav: the paper's "
                  "four; tactical, mems: also gyro_bias_z); auto: from meta.json's noise block, "
                  "else from the static window's measured noise and gyro bias "
                  "(identification/grade.h, choose_grade), recorded as grade_choice")
      ->capture_default_str();
  cmd->add_option("--param", args->params,
                  "KEY=VALUE algorithm parameter (see optimizers/README.md); distances "
                  "d_initial, d_min, d_max, dist_threshold are in the normalised box, or in "
                  "sigma units with the suffix _sigma (d_initial_sigma=0.05)");
  cmd->add_option("--seed", args->seed, "random seed")->capture_default_str()->check(seed_value());
  cmd->add_option("--iterations", args->iterations, "iteration budget (0 = none)")
      ->capture_default_str()
      ->check(whole_in(0, 10000000));
  cmd->add_option("--evaluations", args->evaluations, "evaluation budget (0 = none)")
      ->capture_default_str()
      ->check(whole_in(0, 1000000000));
  cmd->add_option("--alignment", args->alignment, "per-candidate | fixed")->capture_default_str();
  cmd->add_option("--window-s", args->window_s, kWindowWithDefaultHelp)
      ->check(number_in(0.0, kMaxWindowS));
  add_initial_attitude_options(cmd, args->initial_attitude);
  cmd->add_option("--threads", args->threads, "OpenMP threads (0 = all, 1 = serial)")
      ->capture_default_str()
      ->check(whole_in(0, kMaxThreads));
  cmd->add_flag("--no-reference-optimum", args->no_reference,
                "skip the data's own optimum (multi-start local fit, cached in the dataset dir)");
  cmd->add_flag("--positions", args->positions, "record every particle's position per iteration");
  add_output_force_flag(cmd, &args->force);
  cmd->add_option("--uncertainty-replicas", args->uncertainty_replicas,
                  "noise replicas for the estimate's sd and flags (0 = no uncertainty)")
      ->capture_default_str()
      ->check(whole_in(0, 100000));
  cmd->add_flag("--fixed-box", args->fixed_box,
                "keep the search box as given: an estimate at its edge is flagged at_box_edge. "
                "Default: a box whose estimate presses an edge is widened on that side (by half "
                "its width) and searched again, up to the grade's physical limits "
                "(identification/box_widening.h), each widening recorded in box_widening");
  cmd->add_option("--max-widenings", args->max_widenings,
                  "most re-runs of the search in a widened box")
      ->capture_default_str()
      ->check(whole_in(1, 32));
  cmd->add_flag("--gyro-bias-at-rest", args->gyro_bias_at_rest,
                "measure the gyro biases as the static window's mean rate less the Earth rate "
                "(nav/gyro_at_rest.h) instead of searching them; the window must end before the "
                "motors start, so that a motor offset (gyro_motor_offset_*) is told apart from "
                "the bias. Needs --initial-attitude level+heading or given");
  cmd->add_option("--fitness", args->fitness,
                  "what steers the search: fast (a second-order model of the residuals, used when "
                  "its check against the exact kernel passes) | exact. The exact kernel scores "
                  "every reported number either way (search_fitness in the result)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "result JSON file (default: stdout)");
  add_verbosity_flags(cmd, args->verbosity);
  cmd->callback([args] { run_identify(*args); });
}

}  // namespace insid::cli
