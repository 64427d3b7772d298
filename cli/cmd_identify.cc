// insid identify: find the sensor errors of a dataset with GA / PSO / PIO / DVPIO or a reference
// baseline (CMA-ES, DE, compass, LM, BOBYQA, Nelder-Mead, EKF-RTS).
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/initial_attitude_cli.h"
#include "cli/progress.h"
#include "core/dataset.h"
#include "core/fitness.h"
#include "core/units.h"
#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/uncertainty.h"
#include "optimizers/registry.h"

namespace insid::cli {
namespace {

// insid's estimates next to the autopilot's own (meta.json "autopilot_estimates", written by
// `insid import ardupilot`), for each autopilot estimate of the imported IMU: both values with
// both sides' uncertainties. insid's sd is the result's "parameters" sd (its sd_source says
// which); the autopilot's is the scatter of its logged estimate over the airborne part, with one
// logging step's rounding (resolution / sqrt 12) added: the EKF logs no variance. The difference
// is insid minus the autopilot's airborne mean (its value at the window's end when there is no
// airborne part), over the root sum of squares of the two sd.
nlohmann::json autopilot_comparison_json(const nlohmann::json& result, const nlohmann::json& ap) {
  nlohmann::json compared = nlohmann::json::array(), not_compared = nlohmann::json::array();
  for (const nlohmann::json& e : ap.at("estimates")) {
    const std::string name = e.at("effect");
    const std::string label =
        e.at("source").get<std::string>() + " (" + e.at("imu").get<std::string>() + ")";
    if (!e.at("applies_to_imported_imu").get<bool>()) {
      // "refers_to" says which sensor the estimate belongs to (imports before it: one IMU).
      not_compared.push_back(
          {{"autopilot", label},
           {"why", "refers to " + e.value("refers_to", std::string("another IMU")) +
                       ", not to the imported " + ap.value("imported_imu", std::string("IMU"))}});
      continue;
    }
    const nlohmann::json* mine = nullptr;
    if (result.contains("parameters"))
      for (const nlohmann::json& p : result["parameters"])
        if (p.at("name") == name) mine = &p;
    if (mine == nullptr) {
      not_compared.push_back(
          {{"autopilot", label}, {"why", "not estimated by this run (--estimate " + name + ")"}});
      continue;
    }
    const bool has_mean = !e.at("airborne_mean_si").is_null();
    const double ap_value =
        has_mean ? e["airborne_mean_si"].get<double>() : e.at("end_si").get<double>();
    const double rounding = e.at("resolution_si").get<double>() / std::sqrt(12.0);
    // The estimator's own sd where it logs one (PX4's *_bias_variance), else the scatter of the
    // estimate in flight with one logging step's rounding (ArduPilot logs no variance).
    const bool own_sd = e.contains("sd_si") && !e["sd_si"].is_null();
    const double ap_sd =
        own_sd ? e["sd_si"].get<double>()
               : std::hypot(e["airborne_sd_si"].is_null() ? 0.0 : e["airborne_sd_si"].get<double>(),
                            rounding);
    const double insid_value = mine->at("estimate").get<double>();
    nlohmann::json c = {
        {"name", name},
        {"si_unit", e.at("si_unit")},
        {"insid_estimate_si", insid_value},
        {"insid_sd_si", mine->value("sd", nlohmann::json(nullptr))},
        {"insid_sd_source", mine->value("sd_source", nlohmann::json(nullptr))},
        {"autopilot_source", label},
        {"autopilot_value_si", ap_value},
        {"autopilot_value_is", has_mean ? "airborne mean" : "value at the window's end"},
        {"autopilot_sd_si", ap_sd},
        {"autopilot_sd_is",
         own_sd ? "the estimator's own sd" : "scatter in flight with the logging step's rounding"},
        {"autopilot_end_si", e.at("end_si")},
        {"difference_si", insid_value - ap_value}};
    if (!c["insid_sd_si"].is_null()) {
      const double combined = std::hypot(c["insid_sd_si"].get<double>(), ap_sd);
      c["combined_sd_si"] = combined;
      c["difference_over_combined_sd"] = combined > 0 ? (insid_value - ap_value) / combined : 0.0;
    }
    compared.push_back(c);
  }
  return {{"autopilot", ap.value("autopilot", "")},
          {"autopilot_sd",
           "the estimator's own sd where it logs a variance (PX4); else the "
           "scatter of the logged estimate over the airborne part with one "
           "logging step's rounding (resolution / sqrt 12: ArduPilot logs no "
           "variance); per row: autopilot_sd_is"},
          {"compared", compared},
          {"not_compared", not_compared}};
}

std::string autopilot_comparison_table(const nlohmann::json& cmp) {
  std::string t = "insid against the autopilot (" + cmp.at("autopilot").get<std::string>() +
                  "; autopilot sd = its own where logged, else its scatter in flight):\n";
  char line[256];
  std::snprintf(line, sizeof line, "  %-13s %-26s %-40s %s\n", "parameter", "insid +- sd",
                "autopilot +- sd (source)", "diff/sd");
  t += line;
  for (const nlohmann::json& c : cmp.at("compared")) {
    const bool gyro = c.at("name").get<std::string>().rfind("gyro", 0) == 0;
    const double k = gyro ? kRadToDeg : 1e3 / kStandardGravity_mps2;
    const char* unit = gyro ? "deg/s" : "mg";
    char mine[64], theirs[96], ratio[32] = "-";
    if (c.at("insid_sd_si").is_null())
      std::snprintf(mine, sizeof mine, "%.4g (no sd) %s", c["insid_estimate_si"].get<double>() * k,
                    unit);
    else
      std::snprintf(mine, sizeof mine, "%.4g +- %.2g %s", c["insid_estimate_si"].get<double>() * k,
                    c["insid_sd_si"].get<double>() * k, unit);
    std::snprintf(theirs, sizeof theirs, "%.4g +- %.2g (%s)",
                  c["autopilot_value_si"].get<double>() * k, c["autopilot_sd_si"].get<double>() * k,
                  c["autopilot_source"].get<std::string>().c_str());
    if (c.contains("difference_over_combined_sd"))
      std::snprintf(ratio, sizeof ratio, "%.2f", c["difference_over_combined_sd"].get<double>());
    std::snprintf(line, sizeof line, "  %-13s %-26s %-40s %s\n",
                  c["name"].get<std::string>().c_str(), mine, theirs, ratio);
    t += line;
  }
  for (const nlohmann::json& n : cmp.at("not_compared"))
    t += "  not compared: " + n.at("autopilot").get<std::string>() + ": " +
         n.at("why").get<std::string>() + "\n";
  return t;
}

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
  std::string out;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;
};

void run_identify(const IdentifyArgs& args) {
  // The output is checked before the work: never an input, a file of others only with --force.
  const OutputGuard guard{dataset_input_files(args.data_dir), args.force};
  check_output_file(args.out, guard);
  if (args.iterations == 0 && args.evaluations == 0)
    throw UsageError("--iterations 0 and --evaluations 0: no budget; give at least one of them");
  if (args.uncertainty_replicas > 0 && args.uncertainty_replicas < 10)
    throw UsageError("--uncertainty-replicas " + std::to_string(args.uncertainty_replicas) +
                     ": expected 0 (no uncertainty) or at least 10 replicas");
  auto dataset = std::make_shared<const Dataset>(load_dataset(args.data_dir));
  // The grade sets the search unit of every NAME given without SIGMA and the default set:
  // nav (the catalogue) the paper's four, as always; tactical and mems the x/y/z gyro and x/y
  // accelerometer biases (the z gyro is observable once the heading comes from the GNSS course
  // or the flight turns; the uncertainty flags it not_observable when it is not).
  const GradeAndWindow settled = settle_grade_and_window(*dataset, args.grade, args.window_s);
  const SensorGrade& grade = sensor_grade(settled.grade.grade);
  std::vector<EstimatedParameter> estimated;
  for (const std::string& e : args.estimate)
    estimated.push_back(parse_option("--estimate", [&] { return grade.parameter(e); }));
  if (estimated.empty()) {
    if (grade.name == "nav") {
      estimated = EstimatedParameter::paper_four();
    } else {
      for (const char* name :
           {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y", "gyro_bias_z"})
        estimated.push_back(grade.parameter(name));
    }
  }

  NavigationOptions nav_options;
  nav_options.alignment =
      parse_option("--alignment", [&] { return alignment_mode_from_string(args.alignment); });
  nav_options.initial_attitude = initial_attitude_options(args.initial_attitude);
  nav_options.window_s = settled.window_s;
  // The gyrocompass feasibility check meets the search box's gyro biases.
  std::vector<std::string> names;
  std::vector<double> max_abs_si;
  for (const EstimatedParameter& p : estimated) {
    names.push_back(p.name);
    max_abs_si.push_back(std::max(std::abs(p.lower_sigma), std::abs(p.upper_sigma)) *
                         std::abs(p.sigma));
  }
  nav_options.initial_attitude.gyro_bias_allowance_rad_s = gyro_bias_allowance(names, max_abs_si);
  auto navigation = std::make_shared<const NavigationProblem>(dataset, nav_options);
  ParameterMapping mapping(estimated);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = args.threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = args.threads;
  const InsIdentificationProblem problem(navigation, mapping, FitnessKind::kEq15, evaluator);

  const opt::ParameterMap overrides = parse_option("--param", [&] {
    return parse_algorithm_params(args.params, mapping, parse_option("--algo", [&] {
                                    return opt::default_parameters(args.algorithm);
                                  }));
  });
  opt::RunConfig config;
  config.seed = args.seed;
  config.max_iterations = args.iterations;
  config.max_evaluations = args.evaluations;
  config.record_positions = args.positions;
  auto optimizer = parse_option("", [&] {  // an unknown --algo, a --param it does not take
    return opt::make_optimizer(args.algorithm, problem.bounds(), config, overrides);
  });
  ProgressPrinter progress("insid identify", args.verbosity);
  progress.note(settled.line());
  if (auto* ekf = dynamic_cast<EkfRtsOptimizer*>(optimizer.get())) ekf->set_grade(grade.name);

  // ask / evaluate / tell, with progress on stderr (opt::step also feeds the baselines that
  // need residual vectors or the problem itself: lm, ekf-rts). The status shows the iterations
  // done; the closing line says how the run ended and where its best was found (a restarting
  // baseline such as lm spends the budget on restarts after converging).
  const std::string budget = args.iterations > 0 ? "/" + std::to_string(args.iterations) : "";
  int best_at_iteration = 0;
  double best_so_far = std::numeric_limits<double>::infinity();
  while (!optimizer->done()) {
    opt::step(*optimizer, problem);
    const opt::Result& live = optimizer->result();
    if (live.best_f < best_so_far) {
      best_so_far = live.best_f;
      best_at_iteration = live.iterations;
    }
    progress.status(args.algorithm + " iteration " + std::to_string(live.iterations) + budget +
                    ", evaluations " + std::to_string(live.evaluations) + ", best " +
                    short_number(live.best_f));
  }
  progress.finish();
  {
    const opt::Result& done = optimizer->result();
    progress.note(args.algorithm + " stopped after " + std::to_string(done.iterations) +
                  " iteration(s) and " + std::to_string(done.evaluations) + " evaluations (" +
                  std::string(opt::to_string(done.termination)) + "); best " +
                  short_number(done.best_f) + " first reached at iteration " +
                  std::to_string(best_at_iteration));
  }
  const opt::Result& result = optimizer->result();

  nlohmann::json out = optimizer_result_json(result, mapping);
  if (const auto* ekf = dynamic_cast<const EkfRtsOptimizer*>(optimizer.get()))
    out["ekf"] = ekf->report_json(mapping);
  out["format"] = "insid-identify/2";  // /2: estimate_sigma -> estimate_in_sigma_units, parameters
  out["build"] = build_info_json();
  out["data"] = args.data_dir;
  out["alignment"] = to_string(nav_options.alignment);
  out["window_s"] = nav_options.window_s;
  out["initial_attitude"] = initial_attitude_json(*navigation, mapping.to_errors(result.best_x));
  out["fitness_kind"] = "eq15";
  if (args.grade != "auto" || grade.name != "nav") out["grade"] = grade.name;
  out.update(settled.to_json());
  for (const EstimatedParameter& p : estimated)
    out["estimated"].push_back({{"name", p.name},
                                {"sigma", p.sigma},
                                {"lower_sigma", p.lower_sigma},
                                {"upper_sigma", p.upper_sigma}});
  std::optional<ReferenceOptimum> ref;
  if (!args.no_reference) {
    ref = cached_reference_optimum(args.data_dir, problem,
                                   [&progress](const std::string& text) { progress.note(text); });
    out["reference_optimum"] = ref->to_json(mapping);
  }
  add_run_assessment_json(out, result, mapping, dataset->meta.injected, ref ? &*ref : nullptr);
  // How sure the estimate is, the same way whatever found it (identification/uncertainty.h).
  if (args.uncertainty_replicas > 0) {
    UncertaintyOptions uo;
    uo.replicas = args.uncertainty_replicas;
    uo.criterion = criterion_for_algorithm(args.algorithm);
    uo.threads = args.threads;
    const UncertaintyReport report = add_run_uncertainty_json(out, problem, *optimizer, uo);
    if (!progress.quiet()) std::cerr << report.table();
  }
  // The autopilot's own estimates of the same errors, when the import recorded them.
  if (!dataset->meta.autopilot_estimates_json.empty()) {
    out["autopilot_comparison"] = autopilot_comparison_json(
        out, nlohmann::json::parse(dataset->meta.autopilot_estimates_json));
    if (!progress.quiet()) std::cerr << autopilot_comparison_table(out["autopilot_comparison"]);
  }
  write_json_output(args.out, out, guard);
}

}  // namespace

opt::ParameterMap parse_algorithm_params(const std::vector<std::string>& items,
                                         const ParameterMapping& mapping,
                                         const opt::ParameterList& own) {
  opt::ParameterMap overrides;
  for (const std::string& item : items) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      throw std::invalid_argument("--param: expected KEY=VALUE, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    const std::string text = item.substr(eq + 1);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(value))
      throw std::invalid_argument("--param " + key + ": expected a finite number, got '" + text +
                                  "'");
    // Distances given in sigma units (e.g. d_initial_sigma=0.05) are converted to the
    // optimizer's normalised box; the algorithm's own "..._sigma" settings are not.
    try {
      const auto [box_key, box_value] = mapping.algorithm_parameter_in_box(key, value, own);
      overrides[box_key] = box_value;  // a key given twice: the last one counts
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--param ") + e.what());
    }
  }
  return overrides;
}

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
  cmd->add_option("--out", args->out, "result JSON file (default: stdout)");
  add_verbosity_flags(cmd, args->verbosity);
  cmd->callback([args] { run_identify(*args); });
}

}  // namespace insid::cli
