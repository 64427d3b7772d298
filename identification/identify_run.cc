#include "identification/identify_run.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/number_text.h"
#include "data/plausibility.h"
#include "identification/box_widening.h"
#include "identification/ekf_rts.h"
#include "kernel/build_info.h"
#include "model/units.h"
#include "nav/initial_attitude_json.h"
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
    const bool gyro = effect_info(c.at("name").get<std::string>()).sensor == EffectSensor::kGyro;
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

// One search of the box of `estimated`: the navigation problem (its gyrocompass allowance from
// the box), the Eq. 15 problem and the optimizer's ask / evaluate / tell loop with progress.
struct Search {
  std::shared_ptr<const NavigationProblem> navigation;
  std::unique_ptr<InsIdentificationProblem> problem;
  /// What the optimizer was scored with (the fast search fitness or `problem` itself).
  std::unique_ptr<SearchProblem> search_problem;
  std::unique_ptr<opt::Optimizer> optimizer;
  int best_at_iteration = 0;
  /// The optimizer's result with best_f the exact kernel's Eq. 15 of best_x (what is reported);
  /// best_f_search is the search fitness's value there.
  opt::Result result;
  double best_f_search = 0.0;
};

// `overrides`: the algorithm's parameters in the normalised box (algorithm_params_in_box of the
// first box: a widened box keeps the normalised distances). `first_note` is told once the
// optimizer accepted them (a bad parameter is the first line a user sees).
Search run_search(const IdentifySpec& spec, const std::shared_ptr<const Dataset>& dataset,
                  NavigationOptions navigation_options,
                  const std::vector<EstimatedParameter>& estimated, const SensorGrade& grade,
                  const opt::ParameterMap& overrides, const std::string& first_note,
                  const IdentifyProgress& progress) {
  Search search;
  // The gyrocompass feasibility check meets the search box's gyro biases.
  navigation_options.initial_attitude.gyro_bias_allowance_rad_s =
      gyro_bias_allowance_rad_s(estimated);
  search.navigation = std::make_shared<const NavigationProblem>(dataset, navigation_options);
  std::optional<GyroAtRest> rest;
  if (spec.gyro_bias_at_rest) {
    try {
      rest = gyro_at_rest(*search.navigation);
    } catch (const std::invalid_argument& e) {
      throw IdentifySpecError("gyro_bias_at_rest", e.what());
    }
  }
  ParameterMapping mapping(estimated, {}, rest);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = spec.threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = spec.threads;
  search.problem = std::make_unique<InsIdentificationProblem>(search.navigation, mapping,
                                                              FitnessKind::kEq15, evaluator);
  const InsIdentificationProblem& problem = *search.problem;
  opt::RunConfig config;
  config.seed = spec.seed;
  config.max_iterations = spec.iterations;
  config.max_evaluations = spec.evaluations;
  config.record_positions = spec.record_positions;
  try {  // a parameter the optimizer does not take, or a value it refuses
    search.optimizer = opt::make_optimizer(spec.algorithm, problem.bounds(), config, overrides);
  } catch (const std::invalid_argument& e) {
    throw IdentifySpecError("params", e.what());
  }
  if (!first_note.empty() && progress.note) progress.note(first_note);
  opt::Optimizer& optimizer = *search.optimizer;
  if (auto* ekf = dynamic_cast<EkfRtsOptimizer*>(&optimizer)) ekf->set_grade(grade);
  // The baselines that see residual vectors or the problem itself search on the exact kernel.
  const bool fitness_only = dynamic_cast<opt::ProblemConsumer*>(&optimizer) == nullptr &&
                            dynamic_cast<opt::ResidualConsumer*>(&optimizer) == nullptr;
  search.search_problem = std::make_unique<SearchProblem>(
      problem, fitness_only ? spec.search_fitness : SearchFitnessKind::kExact);
  if (spec.search_fitness == SearchFitnessKind::kFast && progress.note) {
    const SearchProblem& s = *search.search_problem;
    const nlohmann::json j = s.to_json();
    if (!fitness_only)
      progress.note("search fitness: exact (" + spec.algorithm + " reads the exact kernel)");
    else if (s.uses_fast())
      progress.note("search fitness: fast (second-order residual model, " +
                    number_text(j["fast"]["check_max_relative_difference"].get<double>(), 2) +
                    " of the exact Eq. 15 on its check points); reported numbers: exact");
    else
      progress.note("search fitness: exact (" + j["reason"].get<std::string>() + ")");
  }

  // ask / evaluate / tell, with progress (opt::step also feeds the baselines that need residual
  // vectors or the problem itself: lm, ekf-rts). The status shows the iterations done; the
  // closing line says how the run ended and where its best was found (a restarting baseline
  // such as lm spends the budget on restarts after converging).
  // "/40" appended, not "/" + s: GCC 12's -Wrestrict misreads that insert at the front here.
  std::string budget;
  if (spec.iterations > 0) budget.append("/").append(std::to_string(spec.iterations));
  double best_so_far = std::numeric_limits<double>::infinity();
  while (!optimizer.done()) {
    opt::step(optimizer, *search.search_problem);
    const opt::Result& live = optimizer.result();
    if (live.best_f < best_so_far) {
      best_so_far = live.best_f;
      search.best_at_iteration = live.iterations;
    }
    if (progress.status)
      progress.status(spec.algorithm + " iteration " + std::to_string(live.iterations) + budget +
                      ", evaluations " + std::to_string(live.evaluations) + ", best " +
                      number_text(live.best_f, 6));
  }
  if (progress.finish) progress.finish();
  // The exact kernel's Eq. 15 of the best point: the reported fitness.
  search.result = optimizer.result();
  search.best_f_search = search.result.best_f;
  search.result.best_f =
      search.search_problem->exact_fitness(std::span(&search.result.best_x, 1)).front();
  return search;
}

// "gyro_bias_x upper 4 -> 8 sigma (1440 -> 2880 deg/h)" for the progress line.
std::string widening_text(const BoxWidening& w, const std::vector<EstimatedParameter>& estimated) {
  double sigma_si = 1.0;
  for (const EstimatedParameter& p : estimated)
    if (p.name == w.parameter) sigma_si = p.sigma;
  const auto [unit, per_si] = engineering_unit(std::string(effect_info(w.parameter).unit));
  return w.parameter + " " + w.side + " " + number_text(w.from_sigma, 4) + " -> " +
         number_text(w.to_sigma, 4) + " sigma (" +
         number_text(w.from_sigma * sigma_si * per_si, 4) + " -> " +
         number_text(w.to_sigma * sigma_si * per_si, 4) + " " + unit +
         (w.to_physical_limit ? ", the physical limit" : "") + ")";
}

}  // namespace

IdentifyReport identify(const IdentifySpec& spec, const IdentifyProgress& progress) {
  if (std::optional<IdentifySpecError> problem = spec_problem(spec)) throw *problem;
  const auto note = [&progress](const std::string& text) {
    if (progress.note) progress.note(text);
  };
  const std::shared_ptr<const Dataset> dataset =
      spec.dataset ? spec.dataset : std::make_shared<const Dataset>(load_dataset(spec.data_dir));
  // Data that cannot be right are refused before the work; doubtful ones said (the result's
  // "plausibility", data/plausibility.h).
  const PlausibilityReport plausibility = check_plausibility(*dataset);
  if (plausibility.refused()) {
    std::string why;
    for (const PlausibilityFinding& f : plausibility.findings)
      if (f.level == PlausibilityFinding::Level::kRefusal)
        why += (why.empty() ? "" : "; ") + f.text();
    throw std::runtime_error(why);
  }
  IdentifyReport report;
  report.setup = identify_setup(spec, *dataset);
  IdentifySetup& setup = report.setup;
  const SensorGrade& grade = *setup.grade;
  opt::ParameterInfoList own;
  try {
    own = opt::parameter_info(spec.algorithm);
  } catch (const std::invalid_argument& e) {  // validate() checked it; kept for the wording
    throw IdentifySpecError("algorithm", "algorithm: " + std::string(e.what()));
  }
  const opt::ParameterMap overrides =
      algorithm_params_in_box(spec.params, ParameterMapping(setup.estimated), own);

  // The search, and again in a wider box while an estimate presses an edge that is not the
  // grade's physical limit (identification/box_widening.h).
  const std::vector<EstimatedParameter> first_box = setup.estimated;
  Search search = run_search(spec, dataset, setup.navigation, setup.estimated, grade, overrides,
                             setup.settled.line(), progress);
  auto closing_line = [&](const Search& s) {
    const opt::Result& r = s.result;
    note(spec.algorithm + " stopped after " + std::to_string(r.iterations) + " iteration(s) and " +
         std::to_string(r.evaluations) + " evaluations (" +
         std::string(opt::to_string(r.termination)) + "); best " + number_text(r.best_f, 6) +
         (s.search_problem->uses_fast()
              ? " (exact; the search fitness said " + number_text(s.best_f_search, 6) + ")"
              : "") +
         " first reached at iteration " + std::to_string(s.best_at_iteration));
  };
  closing_line(search);
  // A motor offset differs from its bias only where the motors are off, or where the bias is
  // measured at rest: say which, and how long.
  if (const std::optional<GyroAtRest>& rest = search.problem->mapping().gyro_at_rest()) {
    const Eigen::Vector3d mean_deg_s = (rest->mean_omega_ib_b - rest->omega_ie_b) * kRadToDeg;
    note("gyro biases measured at rest over " + number_text(rest->t_begin_s, 6) + "-" +
         number_text(rest->t_end_s, 6) + " s (" + std::to_string(rest->samples) +
         " samples): mean rate " + number_text(mean_deg_s.x(), 4) + ", " +
         number_text(mean_deg_s.y(), 4) + ", " + number_text(mean_deg_s.z(), 4) +
         " deg/s, the Earth rate removed");
  } else if (std::any_of(setup.estimated.begin(), setup.estimated.end(),
                         [](const EstimatedParameter& p) {
                           return effect_info(p.name).kind == EffectKind::kMotorOffset;
                         })) {
    const NavigationProblem& nav = *search.navigation;
    double off_s = 0.0, on_s = 0.0;
    for (std::size_t k = nav.nav_begin(); k < dataset->imu.size(); ++k) {
      const double dt = dataset->imu[k].t_s - dataset->imu[k - 1].t_s;
      on_s += nav.motor_on(k) * dt;
      off_s += (1.0 - nav.motor_on(k)) * dt;
    }
    note("motor offsets: the navigation holds " + number_text(off_s, 3) +
         " s with the motors off and " + number_text(on_s, 3) +
         " s with them on; only the motors-off part tells an offset from its bias (a short one "
         "shows as a large sd on both; a shorter static window, --align-s, lengthens it)");
  }
  nlohmann::json rounds = nlohmann::json::array();
  auto round_json = [&](const Search& s) {
    const opt::Result& r = s.result;
    nlohmann::json box = nlohmann::json::object();
    for (const EstimatedParameter& p : s.problem->mapping().parameters())
      box[p.name] = {p.lower_sigma, p.upper_sigma};
    const Eigen::VectorXd v = s.problem->mapping().to_sigma(r.best_x);
    rounds.push_back(
        {{"box_sigma", box},
         {"best_fitness", r.best_f},
         {"evaluations", r.evaluations},
         {"estimate_in_sigma_units", std::vector<double>(v.data(), v.data() + v.size())}});
  };
  round_json(search);
  std::vector<BoxWidening> widenings;
  std::string widening_stopped;
  for (int round = 1; spec.box_widening.enabled; ++round) {
    const Eigen::VectorXd value_sigma =
        search.problem->mapping().to_sigma(search.optimizer->result().best_x);
    std::vector<EstimatedParameter> wider = setup.estimated;
    const std::vector<BoxWidening> moved =
        widen_pressed_bounds(wider, value_sigma, grade, spec.box_widening, round);
    if (moved.empty()) break;
    if (round > spec.box_widening.max_rounds) {
      widening_stopped = "after " + std::to_string(spec.box_widening.max_rounds) +
                         " widenings an estimate still presses its box (max_rounds)";
      break;
    }
    std::string line;
    for (const BoxWidening& w : moved) line += (line.empty() ? "" : "; ") + widening_text(w, wider);
    note("box widened (round " + std::to_string(round) + "): " + line);
    try {
      search = run_search(spec, dataset, setup.navigation, wider, grade, overrides, "", progress);
    } catch (const IdentifySpecError&) {
      throw;
    } catch (const std::exception& e) {
      // A wider gyro box the gyrocompass cannot hold (or any set-up the data refuse): keep the
      // last box that ran, say why.
      widening_stopped = "the wider box could not be searched: " + std::string(e.what());
      note("box widening stopped: " + widening_stopped);
      break;
    }
    closing_line(search);
    round_json(search);
    setup.estimated = wider;
    setup.navigation.initial_attitude.gyro_bias_allowance_rad_s = gyro_bias_allowance_rad_s(wider);
    widenings.insert(widenings.end(), moved.begin(), moved.end());
  }
  const std::shared_ptr<const NavigationProblem>& navigation = search.navigation;
  const InsIdentificationProblem& problem = *search.problem;
  const ParameterMapping& mapping = problem.mapping();
  const opt::Optimizer& optimizer = *search.optimizer;
  const opt::Result& result = search.result;
  report.optimizer_result = result;

  nlohmann::json& out = report.result;
  out = optimizer_result_json(result, mapping);
  // Which fitness steered the search (its history) and which scored the reported numbers.
  out["search_fitness"] = search.search_problem->to_json();
  out["search_fitness"]["best_f_search"] = search.best_f_search;
  if (const std::optional<GyroAtRest>& rest = mapping.gyro_at_rest()) {
    const Eigen::Vector3d bias = mapping.to_errors(result.best_x).gyro.bias;
    const auto deg_s = [](const Eigen::Vector3d& v) {
      return std::vector<double>{v.x() * kRadToDeg, v.y() * kRadToDeg, v.z() * kRadToDeg};
    };
    out["gyro_bias_at_rest"] = {
        {"window_s", {rest->t_begin_s, rest->t_end_s}},
        {"samples", rest->samples},
        {"mean_rate_deg_s", deg_s(rest->mean_omega_ib_b)},
        {"earth_rate_deg_s", deg_s(rest->omega_ie_b)},
        {"sd_of_mean_deg_s", deg_s(rest->sd_of_mean_rad_s)},
        {"bias_deg_s", deg_s(bias)},
        {"model",
         "b0 = mean rate - (I + S + M) Earth rate - b_dot t_mid - b_motor u_mid at the estimate "
         "(nav/gyro_at_rest.h); bias_deg_s is b0, the bias with the motors off"}};
  }
  if (const auto* ekf = dynamic_cast<const EkfRtsOptimizer*>(&optimizer))
    out["ekf"] = ekf->report_json(mapping);
  out["format"] = "insid-identify/2";  // /2: estimate_sigma -> estimate_in_sigma_units, parameters
  out["build"] = build_info_json();
  out["data"] = spec.data_dir;
  out["alignment"] = to_string(setup.navigation.alignment);
  out["window_s"] = setup.navigation.window_s;
  out["initial_attitude"] = initial_attitude_json(*navigation, mapping.to_errors(result.best_x));
  out["fitness_kind"] = "eq15";
  out["plausibility"] = plausibility.to_json();
  if (spec.grade != "auto" || grade.name != "nav") out["grade"] = grade.name;
  out.update(setup.settled.to_json());
  for (const EstimatedParameter& p : setup.estimated)
    out["estimated"].push_back({{"name", p.name},
                                {"sigma", p.sigma},
                                {"lower_sigma", p.lower_sigma},
                                {"upper_sigma", p.upper_sigma}});
  // The box's story: the first box, every widening, each round's best, and what
  // still presses a bound: only a physical limit may hold an estimate at its edge.
  const Eigen::VectorXd value_sigma = mapping.to_sigma(result.best_x);
  const std::vector<std::string> at_limit =
      pressed_at_physical_limit(setup.estimated, value_sigma, grade, spec.box_widening);
  const std::vector<std::string> beyond =
      beyond_physical_limit(setup.estimated, value_sigma, grade);
  {
    nlohmann::json& bw = out["box_widening"];
    bw["enabled"] = spec.box_widening.enabled;
    bw["edge_fraction"] = spec.box_widening.edge_fraction;
    bw["growth_of_width"] = spec.box_widening.growth_of_width;
    bw["max_rounds"] = spec.box_widening.max_rounds;
    nlohmann::json first = nlohmann::json::object();
    for (const EstimatedParameter& p : first_box) first[p.name] = {p.lower_sigma, p.upper_sigma};
    bw["first_box_sigma"] = first;
    bw["widenings"] = nlohmann::json::array();
    for (const BoxWidening& w : widenings)
      bw["widenings"].push_back({{"round", w.round},
                                 {"parameter", w.parameter},
                                 {"side", w.side},
                                 {"from_sigma", w.from_sigma},
                                 {"to_sigma", w.to_sigma},
                                 {"to_physical_limit", w.to_physical_limit}});
    bw["rounds"] = rounds;
    bw["stopped"] =
        widening_stopped.empty() ? nlohmann::json(nullptr) : nlohmann::json(widening_stopped);
    nlohmann::json limits = nlohmann::json::object();
    for (const EstimatedParameter& p : setup.estimated) {
      const PhysicalLimit limit = grade.physical_limit(p.name);
      limits[p.name] = {{"limit", limit.limit_si}, {"source", limit.source}};
    }
    bw["physical_limits"] = limits;
    bw["at_physical_limit"] = at_limit;
    bw["beyond_physical_limit"] = beyond;
    bw["evaluations_all_rounds"] = [&] {
      std::int64_t total = 0;
      for (const nlohmann::json& r : rounds) total += r.at("evaluations").get<std::int64_t>();
      return total;
    }();
  }
  for (const std::string& name : at_limit)
    note("box: " + name + " presses its box at the grade's physical limit (" +
         grade.physical_limit(name).source +
         "): not an answer (the flight cannot tell it, or the model lacks something)");
  for (const std::string& name : beyond)
    note("box: " + name + " is beyond the grade's physical limit (" +
         grade.physical_limit(name).source + "): no unit of this grade has that size");
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
    report.uncertainty = add_run_uncertainty_json(out, problem, optimizer, uo);
    // The physical limits' flags beside the uncertainty's own (at_box_edge, ...).
    for (ParameterUncertainty& p : report.uncertainty->parameters) {
      if (std::find(at_limit.begin(), at_limit.end(), p.name) != at_limit.end())
        p.flags.push_back("at_physical_limit");
      if (std::find(beyond.begin(), beyond.end(), p.name) != beyond.end())
        p.flags.push_back("beyond_physical_limit");
    }
    out["parameters"] = report.uncertainty->parameters_json();
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
