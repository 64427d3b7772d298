#include "identification/window_study.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "data/grade_table.h"
#include "identification/local_fit.h"
#include "model/rotation.h"
#include "model/units.h"
#include "optimizers/registry.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::window_study {

Grade grade(const std::string& name) {
  // The grade table's bias sigmas (data/grade_table.h); tactical is no grade of the study.
  if (name == "mems" || name == "nav") {
    const GradeFigures& figures = grade_figures(name);
    return {name, figures.gyro_bias_rad_s, figures.accel_bias_mps2};
  }
  throw std::invalid_argument("window study: grade must be 'mems' or 'nav', got '" + name + "'");
}

namespace {

bool with_gyro_z(const Grade& g, SetUp set_up) {
  return set_up == SetUp::kGradeAlignment && g.name == "mems";
}

}  // namespace

Eigen::VectorXd truth_sigma(const Grade& g, SetUp set_up) {
  if (with_gyro_z(g, set_up)) {
    Eigen::VectorXd t(5);
    t << -2.0, 1.5, 2.0, -1.5, 2.0;
    return t;
  }
  return Eigen::Vector4d(-2.0, 1.5, 2.0, -1.5);
}

ParameterMapping mapping(const Grade& g, SetUp set_up) {
  const int n = with_gyro_z(g, set_up) ? 5 : 4;
  std::vector<EstimatedParameter> p(static_cast<std::size_t>(n));
  const char* names[] = {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y",
                         "gyro_bias_z"};
  for (int k = 0; k < n; ++k) {
    p[static_cast<std::size_t>(k)].name = names[k];
    p[static_cast<std::size_t>(k)].sigma = k < 2 ? g.sigma_accel_mps2 : g.sigma_gyro_rad_s;
  }
  return ParameterMapping(p);
}

std::shared_ptr<const Dataset> flight(const Grade& g, double flight_s, std::uint64_t seed,
                                      SetUp set_up) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("rich");
  cfg.flight_s = flight_s;
  cfg.noise = scenarios::noise_grade(g.name);
  cfg.seed = seed;
  cfg.injected = SensorErrors{};
  if (set_up == SetUp::kGradeAlignment) {
    // The biases on from t = 0 (the alignment sees them: per-candidate alignment removes them).
    if (g.name == "mems") cfg.align_s = 30.0;  // a drone on the pad (identification/mems_study.h)
    cfg.injected =
        mapping(g, set_up).to_errors(mapping(g, set_up).from_sigma(truth_sigma(g, set_up)));
    return std::make_shared<const Dataset>(scenarios::simulate(cfg));
  }
  Dataset ds = scenarios::simulate(cfg);
  // The biases after the alignment window (m = true + noise + b dt: the order of bias and white
  // noise does not matter).
  const SensorErrors injected = mapping(g).to_errors(mapping(g).from_sigma(truth_sigma()));
  for (std::size_t k = 1; k < ds.imu.size(); ++k) {
    ImuSample& s = ds.imu[k];
    if (s.t_s <= ds.meta.align_s + 1e-9) continue;
    apply_imu_errors(injected, s.t_s, s.t_s - ds.imu[k - 1].t_s, s.dtheta_b_rad, s.dv_b_mps);
  }
  ds.meta.injected = nonzero_effects(injected);
  return std::make_shared<const Dataset>(std::move(ds));
}

// Not identify(spec) (identification/identify_run.h): the study measures the landscape itself,
// local fits started at the truth and at the box centre with their Gauss-Newton sd, next to one
// PSO run, on a fixed-alignment stand-in that identify refuses for users (gyrocompassing MEMS
// data, below).
WindowFit fit_window(const std::shared_ptr<const Dataset>& data, const Grade& g, double window_s,
                     int threads, std::uint64_t pso_seed, SetUp set_up) {
  NavigationOptions options;
  options.window_s = window_s;
  if (set_up == SetUp::kFixedGiven) {
    options.alignment = AlignmentMode::kFixed;
    // The stand-in for a given attitude (README of results/window/): gyrocompassed once from the
    // recorded window. On MEMS data that heading is uncertain (sd 2.4 deg over the 600 s
    // window), which insid refuses for users (nav/alignment.h); the study accepts it knowingly,
    // as its tables were measured with it.
    options.initial_attitude.gyrocompass_max_heading_sd_deg = 180.0;
  } else if (g.name == "mems") {
    // Per-candidate levelling on the 30 s window, heading from the GNSS course carried back.
    options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  }  // nav: per-candidate gyrocompassing, the default.
  auto nav = std::make_shared<const NavigationProblem>(data, options);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = threads;
  const ParameterMapping m = mapping(g, set_up);
  const Eigen::VectorXd truth = truth_sigma(g, set_up);
  const InsIdentificationProblem problem(nav, m, FitnessKind::kEq15, evaluator);

  WindowFit out;
  out.window_s = window_s;
  out.windows = nav->num_windows();
  const LocalFitResult at_truth = local_fit(problem, m.from_sigma(truth));
  const LocalFitResult at_centre = local_fit(problem, Eigen::VectorXd::Zero(m.dimension()));
  out.optimum_sigma = at_truth.value_sigma;
  out.from_centre_sigma = at_centre.value_sigma;
  out.fitness_optimum = at_truth.fitness;
  out.fitness_from_centre = at_centre.fitness;
  // Gauss-Newton covariance at the optimum, residual variance from the fit.
  const Eigen::MatrixXd& J = at_truth.jacobian_sigma;
  const double dof = static_cast<double>(J.rows() - J.cols());
  const double s2 = at_truth.sum_squares / std::max(dof, 1.0);
  const Eigen::MatrixXd cov =
      s2 * (J.transpose() * J).ldlt().solve(Eigen::MatrixXd::Identity(J.cols(), J.cols()));
  out.gn_sd_sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  // A swarm on the same landscape at the paper's budget (global search, no local polish).
  opt::RunConfig config;
  config.seed = pso_seed;
  config.max_iterations = 40;
  out.pso_sigma = m.to_sigma(opt::optimize("pso", problem, config).best_x);
  return out;
}

}  // namespace insid::window_study
