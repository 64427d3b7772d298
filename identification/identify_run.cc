#include "identification/identify_run.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/build_info.h"
#include "core/initial_attitude_json.h"
#include "core/number_text.h"
#include "core/units.h"
#include "identification/ekf_rts.h"
#include "optimizers/registry.h"

namespace insid {
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

}  // namespace

IdentifyReport identify(const IdentifySpec& spec, const IdentifyProgress& progress) {
  if (std::optional<IdentifySpecError> problem = spec_problem(spec)) throw *problem;
  const auto note = [&progress](const std::string& text) {
    if (progress.note) progress.note(text);
  };
  const std::shared_ptr<const Dataset> dataset =
      spec.dataset ? spec.dataset : std::make_shared<const Dataset>(load_dataset(spec.data_dir));
  IdentifyReport report;
  report.setup = identify_setup(spec, *dataset);
  const IdentifySetup& setup = report.setup;
  const SensorGrade& grade = *setup.grade;
  auto navigation = std::make_shared<const NavigationProblem>(dataset, setup.navigation);
  ParameterMapping mapping(setup.estimated);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = spec.threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = spec.threads;
  const InsIdentificationProblem problem(navigation, mapping, FitnessKind::kEq15, evaluator);

  opt::ParameterList own;
  try {
    own = opt::default_parameters(spec.algorithm);
  } catch (const std::invalid_argument& e) {  // validate() checked it; kept for the wording
    throw IdentifySpecError("algorithm", "algorithm: " + std::string(e.what()));
  }
  const opt::ParameterMap overrides = algorithm_params_in_box(spec.params, mapping, own);
  opt::RunConfig config;
  config.seed = spec.seed;
  config.max_iterations = spec.iterations;
  config.max_evaluations = spec.evaluations;
  config.record_positions = spec.record_positions;
  std::unique_ptr<opt::Optimizer> optimizer;
  try {  // a parameter the optimizer does not take, or a value it refuses
    optimizer = opt::make_optimizer(spec.algorithm, problem.bounds(), config, overrides);
  } catch (const std::invalid_argument& e) {
    throw IdentifySpecError("params", e.what());
  }
  note(setup.settled.line());
  if (auto* ekf = dynamic_cast<EkfRtsOptimizer*>(optimizer.get()))
    ekf->set_grade(std::string(grade.name));

  // ask / evaluate / tell, with progress (opt::step also feeds the baselines that need residual
  // vectors or the problem itself: lm, ekf-rts). The status shows the iterations done; the
  // closing line says how the run ended and where its best was found (a restarting baseline
  // such as lm spends the budget on restarts after converging).
  // "/40" appended, not "/" + s: GCC 12's -Wrestrict misreads that insert at the front here.
  std::string budget;
  if (spec.iterations > 0) budget.append("/").append(std::to_string(spec.iterations));
  int best_at_iteration = 0;
  double best_so_far = std::numeric_limits<double>::infinity();
  while (!optimizer->done()) {
    opt::step(*optimizer, problem);
    const opt::Result& live = optimizer->result();
    if (live.best_f < best_so_far) {
      best_so_far = live.best_f;
      best_at_iteration = live.iterations;
    }
    if (progress.status)
      progress.status(spec.algorithm + " iteration " + std::to_string(live.iterations) + budget +
                      ", evaluations " + std::to_string(live.evaluations) + ", best " +
                      number_text(live.best_f, 6));
  }
  if (progress.finish) progress.finish();
  const opt::Result& result = optimizer->result();
  note(spec.algorithm + " stopped after " + std::to_string(result.iterations) +
       " iteration(s) and " + std::to_string(result.evaluations) + " evaluations (" +
       std::string(opt::to_string(result.termination)) + "); best " +
       number_text(result.best_f, 6) + " first reached at iteration " +
       std::to_string(best_at_iteration));
  report.optimizer_result = result;

  nlohmann::json& out = report.result;
  out = optimizer_result_json(result, mapping);
  if (const auto* ekf = dynamic_cast<const EkfRtsOptimizer*>(optimizer.get()))
    out["ekf"] = ekf->report_json(mapping);
  out["format"] = "insid-identify/2";  // /2: estimate_sigma -> estimate_in_sigma_units, parameters
  out["build"] = build_info_json();
  out["data"] = spec.data_dir;
  out["alignment"] = to_string(setup.navigation.alignment);
  out["window_s"] = setup.navigation.window_s;
  out["initial_attitude"] = initial_attitude_json(*navigation, mapping.to_errors(result.best_x));
  out["fitness_kind"] = "eq15";
  if (spec.grade != "auto" || grade.name != "nav") out["grade"] = grade.name;
  out.update(setup.settled.to_json());
  for (const EstimatedParameter& p : setup.estimated)
    out["estimated"].push_back({{"name", p.name},
                                {"sigma", p.sigma},
                                {"lower_sigma", p.lower_sigma},
                                {"upper_sigma", p.upper_sigma}});
  std::optional<ReferenceOptimum> ref;
  if (spec.reference_optimum) {
    ref = cached_reference_optimum(spec.data_dir, problem, progress.note);
    out["reference_optimum"] = ref->to_json(mapping);
  }
  add_run_assessment_json(out, result, mapping, dataset->meta.injected, ref ? &*ref : nullptr);
  // How sure the estimate is, the same way whatever found it (identification/uncertainty.h).
  if (spec.uncertainty_replicas > 0) {
    UncertaintyOptions uo;
    uo.replicas = spec.uncertainty_replicas;
    uo.criterion = criterion_for_algorithm(spec.algorithm);
    uo.threads = spec.threads;
    report.uncertainty = add_run_uncertainty_json(out, problem, *optimizer, uo);
    report.tables += report.uncertainty->table();
  }
  // The autopilot's own estimates of the same errors, when the import recorded them.
  if (!dataset->meta.autopilot_estimates_json.empty()) {
    out["autopilot_comparison"] = autopilot_comparison_json(
        out, nlohmann::json::parse(dataset->meta.autopilot_estimates_json));
    report.tables += autopilot_comparison_table(out["autopilot_comparison"]);
  }
  return report;
}

}  // namespace insid
