#include "identification/mems_study.h"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "core/rotation.h"
#include "core/units.h"
#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/identify_run.h"
#include "identification/uncertainty.h"
#include "optimizers/registry.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::mems_study {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

const std::vector<std::string>& parameter_names() {
  static const std::vector<std::string> kNames = {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z",
                                                  "accel_bias_x", "accel_bias_y"};
  return kNames;
}

Eigen::VectorXd truth_si() {
  Eigen::VectorXd t(5);
  t << 0.2 * kDegToRad, -0.15 * kDegToRad, 0.2 * kDegToRad, 20.0 * kMilliG_mps2,
      -15.0 * kMilliG_mps2;
  return t;
}

std::shared_ptr<const Dataset> flight(const Spec& spec, std::uint64_t seed) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("rich");
  cfg.align_s = spec.align_s;
  cfg.flight_s = spec.flight_s;
  cfg.noise = scenarios::noise_grade("mems");
  cfg.seed = seed;
  cfg.injected = SensorErrors{};
  const Eigen::VectorXd t = truth_si();
  for (std::size_t k = 0; k < parameter_names().size(); ++k)
    set_effect(cfg.injected, parameter_names()[k], t[static_cast<Eigen::Index>(k)]);
  Dataset data = scenarios::simulate(cfg);
  if (spec.heading_sd_deg > 0.0) {
    scenarios::HeadingStreamSpec heading;
    heading.sd_deg = spec.heading_sd_deg;
    heading.seed = seed;
    scenarios::add_heading_stream(data, heading);
  }
  return std::make_shared<const Dataset>(std::move(data));
}

InsIdentificationProblem problem(const std::shared_ptr<const Dataset>& data, double window_s,
                                 int threads, const std::string& heading_source) {
  NavigationOptions options;
  options.window_s = window_s;
  options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  if (!heading_source.empty())
    options.initial_attitude.heading_source = heading_source_from_string(heading_source);
  auto navigation = std::make_shared<const NavigationProblem>(data, options);
  const SensorGrade& mems = sensor_grade("mems");
  std::vector<EstimatedParameter> estimated;
  for (const std::string& name : parameter_names()) estimated.push_back(mems.parameter(name));
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = threads;
  return InsIdentificationProblem(navigation, ParameterMapping(estimated), FitnessKind::kEq15,
                                  evaluator);
}

// The filter itself, not identify(spec): the study sets its passes and intervals and its own
// initial-attitude mode, and reads the smoother's sd (identify's "ekf-rts" runs the same filter
// with the grade's set-up, as an optimizer over the Eq. 15 problem).
Answer ekf_rts(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  const auto t0 = std::chrono::steady_clock::now();
  // The EKF runs on the data itself; the window only matters to the fitness methods.
  NavigationOptions options;
  options.initial_attitude.mode = initial_attitude_mode_from_string(spec.ekf_attitude);
  if (!spec.heading_source.empty())
    options.initial_attitude.heading_source = heading_source_from_string(spec.heading_source);
  const auto navigation = std::make_shared<const NavigationProblem>(data, options);
  const SensorGrade& grade = grade_for(*data);  // declared by meta.json's noise: mems
  if (grade.name != "mems")
    throw std::logic_error("mems study: the flight declares grade '" + std::string(grade.name) +
                           "'");
  std::optional<EkfRtsGradeSetup> setup = ekf_grade_setup(*navigation, grade);
  setup->passes = spec.ekf_passes;
  EkfRtsParams params;
  params.update_interval_s = spec.ekf_update_interval_s;
  params.propagation_interval_s = spec.ekf_propagation_interval_s;
  params.use_position = spec.ekf_use_position;
  const EkfRtsResult r = run_ekf_rts(*navigation, params, SensorErrors{}, setup);
  Answer a;
  a.method = "ekf-rts";
  a.estimate_si.resize(5);
  a.sd_si.resize(5);
  a.flags.assign(5, {});
  for (std::size_t k = 0; k < 5; ++k) {
    a.estimate_si[static_cast<Eigen::Index>(k)] = r.estimate.at(parameter_names()[k]);
    a.sd_si[static_cast<Eigen::Index>(k)] = r.std.at(parameter_names()[k]);
  }
  a.wall_s = seconds_since(t0);
  return a;
}

namespace {

// One method on the windowed fitness through the identification pipeline (identify(spec),
// identification/identify_run.h), as `insid identify --grade mems --initial-attitude
// level+heading --window-s W --estimate <the five>` runs it: sd and flags from the uncertainty
// of its final point, the path of every identify result. No reference optimum (the flight has
// no directory to cache it in, and the study judges against the truth).
Answer identified(const std::shared_ptr<const Dataset>& data, const Spec& spec,
                  const std::string& algorithm, std::uint64_t seed, std::int64_t evaluations) {
  const auto t0 = std::chrono::steady_clock::now();
  IdentifySpec is;
  is.dataset = data;
  is.algorithm = algorithm;
  is.estimate = parameter_names();  // NAME alone: the mems grade's sigma, the [-4, 4] box
  is.grade = "mems";
  is.seed = seed;
  is.iterations = 0;
  is.evaluations = evaluations;
  is.window_s = spec.window_s;
  is.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  if (!spec.heading_source.empty())
    is.initial_attitude.heading_source = heading_source_from_string(spec.heading_source);
  is.threads = spec.threads;
  is.reference_optimum = false;
  is.uncertainty_replicas = spec.replicas;
  const IdentifyReport report = identify(is);
  Answer a;
  a.method = algorithm;
  a.estimate_si.resize(5);
  a.sd_si.resize(5);
  for (std::size_t k = 0; k < 5; ++k) {
    const ParameterUncertainty& u = report.uncertainty->parameters[k];
    a.estimate_si[static_cast<Eigen::Index>(k)] = u.estimate_si;
    a.sd_si[static_cast<Eigen::Index>(k)] = u.sd_si.value_or(std::nan(""));
    a.flags.push_back(u.flags);
  }
  a.evaluations = report.optimizer_result.evaluations;
  a.wall_s = seconds_since(t0);
  return a;
}

}  // namespace

Answer lm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  return identified(data, spec, "lm", opt::RunConfig{}.seed, 200);
}

Answer swarm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  return identified(data, spec, spec.swarm, spec.swarm_seed, spec.swarm_evaluations);
}

}  // namespace insid::mems_study
