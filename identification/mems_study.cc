#include "identification/mems_study.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/identify_run.h"
#include "identification/uncertainty.h"
#include "model/rotation.h"
#include "model/units.h"
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

const std::vector<std::string>& parameter_names(const Spec& spec) {
  static const std::vector<std::string> kDrone = {"gyro_bias_x",  "gyro_bias_y",  "gyro_bias_z",
                                                  "accel_bias_x", "accel_bias_y", "accel_bias_z"};
  return spec.kind == "drone" ? kDrone : parameter_names();
}

Eigen::VectorXd truth_si(const Spec& spec, std::uint64_t seed) {
  if (spec.kind != "drone") return truth_si();
  // Uniform in [-m, m] grade sigma per bias from the seed's own stream (scenarios::GaussianRng:
  // mt19937_64, fixed by the standard), independent of the noise streams of the simulation.
  scenarios::GaussianRng rng(scenarios::splitmix64(seed ^ 0x6472'6f6e'6562'6961ULL));
  const SensorGrade& mems = sensor_grade("mems");
  const std::vector<std::string>& names = parameter_names(spec);
  Eigen::VectorXd t(static_cast<Eigen::Index>(names.size()));
  for (std::size_t k = 0; k < names.size(); ++k)
    t[static_cast<Eigen::Index>(k)] =
        (2.0 * rng.uniform() - 1.0) * spec.truth_max_sigma * mems.parameter(names[k]).sigma;
  return t;
}

std::string Spec::validate() const {
  const auto bad = [](const char* field, double value) {
    return std::string("mems_study::Spec.") + field + " = " + std::to_string(value);
  };
  if (kind != "rich" && kind != "drone")
    return "mems_study::Spec.kind = '" + kind + "': must be rich or drone";
  if (!(drone_imu_rate_hz > 0.0 && std::isfinite(drone_imu_rate_hz)))
    return bad("drone_imu_rate_hz", drone_imu_rate_hz) + ": must be > 0";
  if (!(drone_gnss_rate_hz > 0.0 && drone_gnss_rate_hz <= drone_imu_rate_hz))
    return bad("drone_gnss_rate_hz", drone_gnss_rate_hz) + ": must be in (0, the IMU rate]";
  if (!(drone_align_s >= 1.0 && std::isfinite(drone_align_s)))
    return bad("drone_align_s", drone_align_s) + ": must be >= 1 s";
  for (const auto& [field, value] :
       {std::pair{"drone_arw_deg_rth", drone_arw_deg_rth},
        std::pair{"drone_vrw_mps_rth", drone_vrw_mps_rth},
        std::pair{"drone_gnss_vel_sigma_mps", drone_gnss_vel_sigma_mps},
        std::pair{"drone_gnss_pos_sigma_m", drone_gnss_pos_sigma_m}})
    if (!(value >= 0.0 && std::isfinite(value))) return bad(field, value) + ": must be >= 0";
  if (!(truth_max_sigma >= 0.0 && std::isfinite(truth_max_sigma)))
    return bad("truth_max_sigma", truth_max_sigma) + ": must be >= 0";
  if (!(box_sigma > 0.0 && std::isfinite(box_sigma)))
    return bad("box_sigma", box_sigma) + ": must be > 0";
  return "";
}

std::shared_ptr<const Dataset> flight(const Spec& spec, std::uint64_t seed) {
  if (const std::string error = spec.validate(); !error.empty()) throw std::invalid_argument(error);
  if (spec.kind == "drone") {
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario("multicopter");
    cfg.imu_rate_hz = spec.drone_imu_rate_hz;
    cfg.gnss_rate_hz = spec.drone_gnss_rate_hz;
    cfg.align_s = spec.drone_align_s;
    cfg.flight_s = spec.flight_s;
    cfg.noise = scenarios::noise_grade("mems");
    cfg.noise.arw_deg_rth = spec.drone_arw_deg_rth;
    cfg.noise.vrw_mps_rth = spec.drone_vrw_mps_rth;
    cfg.noise.gnss_vel_sigma_mps = spec.drone_gnss_vel_sigma_mps;
    cfg.noise.gnss_pos_sigma_m = spec.drone_gnss_pos_sigma_m;
    cfg.seed = seed;
    cfg.injected = SensorErrors{};
    const Eigen::VectorXd t = truth_si(spec, seed);
    for (std::size_t k = 0; k < parameter_names(spec).size(); ++k)
      set_effect(cfg.injected, parameter_names(spec)[k], t[static_cast<Eigen::Index>(k)]);
    return std::make_shared<const Dataset>(scenarios::simulate(cfg, spec.noise_in_meta));
  }
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
  // Declared by meta.json's noise (mems); a drone flight without a noise block is mems too.
  const SensorGrade& grade = spec.kind == "drone" ? sensor_grade("mems") : grade_for(*data);
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
  const std::vector<std::string>& names = parameter_names(spec);
  const auto n = static_cast<Eigen::Index>(names.size());
  a.estimate_si.resize(n);
  a.sd_si.resize(n);
  a.flags.assign(names.size(), {});
  for (std::size_t k = 0; k < names.size(); ++k) {
    a.estimate_si[static_cast<Eigen::Index>(k)] = r.estimate.at(names[k]);
    a.sd_si[static_cast<Eigen::Index>(k)] = r.std.at(names[k]);
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
                  const std::string& algorithm, std::uint64_t seed, std::int64_t evaluations,
                  const std::vector<std::string>& params = {}) {
  const auto t0 = std::chrono::steady_clock::now();
  IdentifySpec is;
  is.dataset = data;
  is.algorithm = algorithm;
  is.params = params;
  const std::vector<std::string>& names = parameter_names(spec);
  if (spec.kind == "drone") {
    // NAME:SIGMA:LO:HI: the mems grade's sigma, the [-box_sigma, box_sigma] box.
    const SensorGrade& mems = sensor_grade("mems");
    for (const std::string& name : names) {
      char item[160];
      std::snprintf(item, sizeof(item), "%s:%.17g:%.17g:%.17g", name.c_str(),
                    mems.parameter(name).sigma, -spec.box_sigma, spec.box_sigma);
      is.estimate.emplace_back(item);
    }
  } else {
    is.estimate = names;  // NAME alone: the mems grade's sigma, the [-4, 4] box
  }
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
  a.estimate_si.resize(static_cast<Eigen::Index>(names.size()));
  a.sd_si.resize(static_cast<Eigen::Index>(names.size()));
  for (std::size_t k = 0; k < names.size(); ++k) {
    const ParameterUncertainty& u = report.uncertainty->parameters[k];
    a.estimate_si[static_cast<Eigen::Index>(k)] = u.estimate_si;
    a.sd_si[static_cast<Eigen::Index>(k)] = u.sd_si.value_or(std::nan(""));
    a.flags.push_back(u.flags);
  }
  a.uncertainty = report.uncertainty;
  a.evaluations = report.optimizer_result.evaluations;
  a.wall_s = seconds_since(t0);
  return a;
}

}  // namespace

Answer ekf_rts_reported(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  // One evaluation is what the filter asks for; the budget only has to allow it.
  Answer a = identified(data, spec, "ekf-rts", opt::RunConfig{}.seed, 10, spec.ekf_params);
  a.method = "ekf-rts-reported";
  return a;
}

Answer lm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  return identified(data, spec, "lm", opt::RunConfig{}.seed, 200);
}

Answer swarm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec) {
  return identified(data, spec, spec.swarm, spec.swarm_seed, spec.swarm_evaluations);
}

}  // namespace insid::mems_study
