#include "identification/identify.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "base/json_reader.h"
#include "optimizers/random.h"
#include "optimizers/registry.h"

namespace insid {

nlohmann::json ReferenceOptimum::to_json(const ParameterMapping& mapping) const {
  nlohmann::json j;
  for (int k = 0; k < mapping.dimension(); ++k)
    j[kEstimateInSigmaUnits][mapping.parameters()[static_cast<std::size_t>(k)].name] =
        value_sigma[k];
  j["fitness"] = fitness;
  j["evaluations"] = evaluations;
  j["starts"] = starts;
  j["method"] = "multi-start Levenberg-Marquardt + Eq. 15 IRLS";
  return j;
}

ReferenceOptimum ReferenceOptimum::from_json(const nlohmann::json& j,
                                             const ParameterMapping& mapping) {
  ReferenceOptimum optimum;
  optimum.fitness = j.at("fitness").get<double>();
  optimum.evaluations = j.at("evaluations").get<std::int64_t>();
  optimum.starts = j.at("starts").get<int>();
  optimum.value_sigma = estimate_in_sigma_units(j, mapping);
  return optimum;
}

Eigen::VectorXd estimate_in_sigma_units(const nlohmann::json& block,
                                        const ParameterMapping& mapping) {
  const char* key = block.contains(kEstimateInSigmaUnits)      ? kEstimateInSigmaUnits
                    : block.contains(kEstimateInSigmaUnitsOld) ? kEstimateInSigmaUnitsOld
                                                               : nullptr;
  if (key == nullptr)
    throw std::runtime_error(std::string("no estimate: neither \"") + kEstimateInSigmaUnits +
                             "\" nor (before insid-identify/2) \"" + kEstimateInSigmaUnitsOld +
                             "\" is there");
  Eigen::VectorXd value_sigma(mapping.dimension());
  for (int k = 0; k < mapping.dimension(); ++k)
    value_sigma[k] =
        block.at(key).at(mapping.parameters()[static_cast<std::size_t>(k)].name).get<double>();
  return value_sigma;
}

ReferenceOptimum find_reference_optimum(const InsIdentificationProblem& problem, int starts,
                                        std::uint64_t seed, int threads) {
  if (starts < 1) throw std::invalid_argument("find_reference_optimum: starts must be >= 1");
  if (threads < 1) throw std::invalid_argument("find_reference_optimum: threads must be >= 1");
  const int n = problem.dimension();
  // The start points are drawn in order before any fit runs, and the best is taken in start
  // order (the first of equal fitnesses): the same optimum for any number of threads.
  opt::Rng rng(seed);
  std::vector<Eigen::VectorXd> x0(static_cast<std::size_t>(starts), Eigen::VectorXd::Zero(n));
  for (int s = 1; s < starts; ++s)
    for (int j = 0; j < n; ++j) x0[static_cast<std::size_t>(s)][j] = -0.8 + 1.6 * rng.uniform();
  LocalFitOptions options;
  options.max_iterations = 40;
  options.keep_jacobian = false;  // only the estimate and fitness are kept
  // The starts in lock-step: one batch a round for all of them (local_fits).
  const std::vector<LocalFitResult> fits = local_fits(problem, x0, options, threads);
  ReferenceOptimum best;
  best.fitness = std::numeric_limits<double>::infinity();
  for (const LocalFitResult& fit : fits) {
    best.evaluations += fit.evaluations;
    if (fit.fitness < best.fitness) {
      best.fitness = fit.fitness;
      best.value_sigma = fit.value_sigma;
    }
  }
  best.starts = starts;
  return best;
}

namespace {

// Everything that determines the optimum: the data's contents (a dataset replaced in the same
// directory gets a new key), the alignment, the estimated parameters and the fixed effects.
std::string cache_key(const std::string& data_dir, const InsIdentificationProblem& problem) {
  std::ostringstream key;
  key << "data_sha256=" << dataset_digest(data_dir);
  key << ";alignment=" << to_string(problem.navigation().options().alignment);
  // The windowed fitness has its own optimum (W = 0 keeps the keys written before it existed).
  if (problem.navigation().options().window_s > 0.0)
    key << ";window_s=" << opt::format_number(problem.navigation().options().window_s);
  // (gyrocompass, the default, adds nothing: keys without an initial-attitude mode stay valid)
  const InitialAttitudeOptions& attitude = problem.navigation().options().initial_attitude;
  if (attitude.mode != InitialAttitudeMode::kGyrocompass)
    key << ";initial_attitude=" << attitude.describe();
  for (const EstimatedParameter& p : problem.mapping().parameters())
    key << ";" << p.name << ":" << opt::format_number(p.sigma) << ":"
        << opt::format_number(p.lower_sigma) << ":" << opt::format_number(p.upper_sigma);
  for (const auto& [name, value] : nonzero_effects(problem.mapping().base()))
    key << ";base:" << name << "=" << opt::format_number(value);
  if (problem.mapping().gyro_at_rest()) key << ";gyro_bias_at_rest";
  return key.str();
}

}  // namespace

ReferenceOptimum cached_reference_optimum(const std::string& data_dir,
                                          const InsIdentificationProblem& problem,
                                          const std::function<void(const std::string&)>& note) {
  const std::filesystem::path path = std::filesystem::path(data_dir) / "insid-optimum-cache.json";
  const std::string key = cache_key(data_dir, problem);
  nlohmann::json cache = nlohmann::json::object();
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) {
    try {
      cache = read_json_file(path);
    } catch (const std::exception&) {
      cache = nlohmann::json::object();  // a damaged cache is recomputed
    }
  }
  if (cache.is_object() && cache.contains(key)) {
    try {
      return ReferenceOptimum::from_json(cache[key], problem.mapping());
    } catch (const std::exception&) {
      // a damaged entry is recomputed (and overwritten below)
    }
  }
  if (note)
    note("finding the data's own optimum (multi-start local fit, cached in " + path.string() + ")");
  // The starts' linear algebra on the problem's own threads (the optimum does not depend on it).
  ReferenceOptimum opt = find_reference_optimum(
      problem, kReferenceOptimumStarts, kReferenceOptimumSeed, problem.evaluator().threads());
  if (!cache.is_object()) cache = nlohmann::json::object();
  cache[key] = opt.to_json(problem.mapping());
  try {
    write_file_atomic(path, cache.dump(2) + "\n");
  } catch (const std::exception& e) {
    if (note) note("could not cache the optimum (" + std::string(e.what()) + ")");
  }
  return opt;
}

nlohmann::json optimizer_result_json(const opt::Result& result, const ParameterMapping& mapping,
                                     bool include_per_evaluation) {
  nlohmann::json j;
  j["algorithm"]["name"] = result.algorithm;
  for (const auto& [name, value] : result.parameters) j["algorithm"]["parameters"][name] = value;
  j["seed"] = result.seed;
  j["fitness"] = result.best_f;
  j["evaluations"] = result.evaluations;
  j["iterations"] = result.iterations;
  j["wall_s"] = result.wall_time_s;
  j["termination"] = std::string(opt::to_string(result.termination));
  nlohmann::json history = nlohmann::json::array();
  for (const opt::IterationRecord& rec : result.history) {
    nlohmann::json h;
    h["iteration"] = rec.iteration;
    h["evaluations"] = rec.evaluations;
    h["best_fitness"] = rec.best_fitness;
    h["median_fitness"] = rec.median_fitness;
    h["diversity"] = rec.diversity;
    h["phase"] = rec.phase;
    if (rec.d_positive.size() == mapping.dimension()) {
      h["premature"] = rec.premature;
      std::vector<double> dp, dn;
      for (int k = 0; k < mapping.dimension(); ++k) {
        dp.push_back(rec.d_positive[k] * mapping.sigma_per_unit(k));
        dn.push_back(rec.d_negative[k] * mapping.sigma_per_unit(k));
      }
      h["d_positive_sigma"] = dp;
      h["d_negative_sigma"] = dn;
      h["direction_flags"] = rec.direction_flags;
    }
    if (!rec.positions.empty()) {
      nlohmann::json pos = nlohmann::json::array();
      for (const Eigen::VectorXd& x : rec.positions) {
        const Eigen::VectorXd s = mapping.to_sigma(x);
        pos.push_back(std::vector<double>(s.data(), s.data() + s.size()));
      }
      h["positions_sigma"] = pos;
      h["positions_fitness"] = rec.fitness;
    }
    history.push_back(h);
  }
  j["history"] = history;
  if (include_per_evaluation) j["best_per_evaluation"] = result.best_per_evaluation;
  return j;
}

void add_estimate_json(nlohmann::json& out, const ParameterMapping& mapping,
                       const Eigen::VectorXd& value_sigma,
                       const std::optional<std::map<std::string, double>>& injected) {
  for (int k = 0; k < mapping.dimension(); ++k) {
    const EstimatedParameter& p = mapping.parameters()[static_cast<std::size_t>(k)];
    out["estimate"][p.name] = value_sigma[k] * p.sigma;
    out[kEstimateInSigmaUnits][p.name] = value_sigma[k];
    if (injected) {
      const auto it = injected->find(p.name);
      const double truth_sigma = (it == injected->end() ? 0.0 : it->second) / p.sigma;
      out["truth_sigma"][p.name] = truth_sigma;
      out["error_sigma"][p.name] = value_sigma[k] - truth_sigma;
    }
  }
}

void add_run_assessment_json(nlohmann::json& out, const opt::Result& result,
                             const ParameterMapping& mapping,
                             const std::optional<std::map<std::string, double>>& injected,
                             const ReferenceOptimum* optimum) {
  const Eigen::VectorXd best_sigma = mapping.to_sigma(result.best_x);
  add_estimate_json(out, mapping, best_sigma, injected);
  if (optimum == nullptr) return;
  for (int k = 0; k < mapping.dimension(); ++k)
    out["error_vs_optimum_sigma"][mapping.parameters()[static_cast<std::size_t>(k)].name] =
        best_sigma[k] - optimum->value_sigma[k];
  out["optimum_fitness"] = optimum->fitness;
  out["fitness_gap"] = result.best_f - optimum->fitness;
  out["fitness_gap_relative"] = (result.best_f - optimum->fitness) / optimum->fitness;
}

std::vector<EstimatedParameter> default_estimated(const SensorGrade& grade) {
  if (grade.name == "nav") return EstimatedParameter::paper_four();
  std::vector<EstimatedParameter> out;
  for (const char* name :
       {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y", "gyro_bias_z"})
    out.push_back(grade.parameter(name));
  return out;
}

std::vector<EstimatedParameter> identify_parameters(const SensorGrade& grade,
                                                    const std::vector<std::string>& estimate) {
  std::vector<EstimatedParameter> out;
  for (const std::string& e : estimate) out.push_back(grade.parameter(e));
  if (out.empty()) out = default_estimated(grade);
  return out;
}

double gyro_bias_allowance_rad_s(const std::vector<EstimatedParameter>& estimated) {
  double allowance_rad_s = -1.0;  // none estimated yet
  for (const EstimatedParameter& p : estimated)
    if (p.name == "gyro_bias_x" || p.name == "gyro_bias_y")
      allowance_rad_s =
          std::max(allowance_rad_s,
                   std::max(std::abs(p.lower_sigma), std::abs(p.upper_sigma)) * std::abs(p.sigma));
  return allowance_rad_s >= 0.0 ? allowance_rad_s
                                : InitialAttitudeOptions{}.gyro_bias_allowance_rad_s;
}

namespace {

// A parser's message as the error of `field`: named already when it starts with an option
// ("--estimate 'x': ..."), else after the field's name.
IdentifySpecError field_error(const std::string& field, const std::string& what) {
  return IdentifySpecError(field, what.rfind("--", 0) == 0 ? what : field + ": " + what);
}

// KEY and finite VALUE of a KEY=VALUE item.
std::pair<std::string, double> key_value(const std::string& item) {
  const auto eq = item.find('=');
  if (eq == std::string::npos || eq == 0)
    throw IdentifySpecError("params", "params: expected KEY=VALUE, got '" + item + "'");
  const std::string key = item.substr(0, eq);
  const std::string text = item.substr(eq + 1);
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(value))
    throw IdentifySpecError("params",
                            "params " + key + ": expected a finite number, got '" + text + "'");
  return {key, value};
}

}  // namespace

std::optional<IdentifySpecError> spec_problem(const IdentifySpec& spec) {
  if (spec.data_dir.empty() && !spec.dataset)
    return IdentifySpecError("data_dir", "data_dir '': no dataset directory and no dataset given");
  try {
    opt::default_parameters(spec.algorithm);
  } catch (const std::invalid_argument& e) {
    return field_error("algorithm", e.what());
  }
  if (spec.grade != "auto") {
    const std::vector<std::string> names = sensor_grade_names();
    if (std::find(names.begin(), names.end(), spec.grade) == names.end())
      return IdentifySpecError("grade",
                               "grade '" + spec.grade + "': expected auto, nav, tactical or mems");
  }
  for (const std::string& e : spec.estimate) {
    try {
      EstimatedParameter::parse(e);  // the form and the name; the grade's sigma comes later
    } catch (const std::invalid_argument& error) {
      return field_error("estimate", error.what());
    }
  }
  for (const std::string& item : spec.params) {
    try {
      key_value(item);
    } catch (const IdentifySpecError& e) {
      return e;
    }
  }
  if (spec.iterations < 0)
    return IdentifySpecError("iterations",
                             "iterations " + std::to_string(spec.iterations) + ": expected >= 0");
  if (spec.evaluations < 0)
    return IdentifySpecError("evaluations",
                             "evaluations " + std::to_string(spec.evaluations) + ": expected >= 0");
  if (spec.iterations == 0 && spec.evaluations == 0)
    return IdentifySpecError(
        "iterations", "iterations 0 and evaluations 0: no budget; give at least one of them");
  if (spec.window_s) {  // the navigation's own check and wording
    NavigationOptions navigation;
    navigation.window_s = *spec.window_s;
    if (const std::string why = navigation.validate(); !why.empty())
      return IdentifySpecError("window_s", why);
  }
  if (spec.threads < 0)
    return IdentifySpecError("threads", "threads " + std::to_string(spec.threads) +
                                            ": expected >= 0 (0 = all, 1 = serial)");
  if (spec.uncertainty_replicas < 0 ||
      (spec.uncertainty_replicas > 0 && spec.uncertainty_replicas < 10))
    return IdentifySpecError("uncertainty_replicas",
                             "uncertainty_replicas " + std::to_string(spec.uncertainty_replicas) +
                                 ": expected 0 (no uncertainty) or at least 10 replicas");
  if (const std::string why = spec.initial_attitude.validate(); !why.empty())
    return IdentifySpecError("initial_attitude", "initial_attitude: " + why);
  if (const std::string why = spec.box_widening.validate(); !why.empty())
    return IdentifySpecError("box_widening", why);
  if (spec.gyro_bias_at_rest && spec.algorithm == "ekf-rts")
    return IdentifySpecError("gyro_bias_at_rest",
                             "gyro_bias_at_rest: ekf-rts estimates the gyro biases as filter "
                             "states from the navigation start; use it without the rest "
                             "measurement, or a search algorithm or lm with it");
  return std::nullopt;
}

std::string IdentifySpec::validate() const {
  const std::optional<IdentifySpecError> problem = spec_problem(*this);
  return problem ? problem->what() : "";
}

IdentifySetup identify_setup(const IdentifySpec& spec, const Dataset& dataset) {
  IdentifySetup setup;
  // The grade sets the search unit of every NAME given without SIGMA and the default set.
  setup.settled = settle_grade_and_window(dataset, spec.grade, spec.window_s);
  setup.grade = &sensor_grade(setup.settled.grade.grade);
  try {
    setup.estimated = identify_parameters(*setup.grade, spec.estimate);
  } catch (const std::invalid_argument& e) {
    throw field_error("estimate", e.what());
  }
  if (spec.gyro_bias_at_rest) {
    const auto measured = [](const EstimatedParameter& p) { return measured_at_rest(p.name); };
    if (spec.estimate.empty())  // the default set, less what the rest window measures
      std::erase_if(setup.estimated, measured);
    for (const EstimatedParameter& p : setup.estimated)
      if (measured(p))
        throw field_error("estimate", "--estimate '" + p.name +
                                          "': the gyro biases are measured at rest "
                                          "(--gyro-bias-at-rest); leave them out");
    if (setup.estimated.empty())
      throw field_error("estimate",
                        "--estimate: with the gyro biases measured at rest nothing is left to "
                        "estimate; name the parameters");
  }
  setup.navigation.alignment = spec.alignment;
  setup.navigation.initial_attitude = spec.initial_attitude;
  setup.navigation.window_s = setup.settled.window_s;
  // The gyrocompass feasibility check meets the search box's gyro biases.
  setup.navigation.initial_attitude.gyro_bias_allowance_rad_s =
      gyro_bias_allowance_rad_s(setup.estimated);
  return setup;
}

opt::ParameterMap algorithm_params_in_box(const std::vector<std::string>& items,
                                          const ParameterMapping& mapping,
                                          const opt::ParameterInfoList& own) {
  opt::ParameterMap overrides;
  for (const std::string& item : items) {
    const auto [key, value] = key_value(item);
    // Distances given in sigma units (e.g. d_initial_sigma=0.05) are converted to the
    // optimizer's normalised box; every other setting passes as given.
    try {
      const auto [box_key, box_value] = mapping.algorithm_parameter_in_box(key, value, own);
      overrides[box_key] = box_value;  // a key given twice: the last one counts
    } catch (const std::invalid_argument& e) {
      throw IdentifySpecError("params", std::string("params ") + e.what());
    }
  }
  return overrides;
}

}  // namespace insid
