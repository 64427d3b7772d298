// How close a cheaper search fitness can come to the exact one (issue 47's criterion 1,
// results/perf/fast-fitness/): a Taylor model of the residual vector in the estimated
// parameters, built at the box centre from exact runs, against the exact kernel's Eq. 15.
//
// The model: with x the normalised parameters and r(x) the residual vector (dvE_t, dvN_t) of
// NavigationProblem::residuals,
//   r(x) ~ r(0) + J x                                    (first order), and
//   r(x) ~ r(0) + J x + 1/2 sum_i x_i^2 H_ii + sum_{i<j} x_i x_j H_ij   (second order),
// J by central differences, H_ii by central second differences, H_ij by forward ones, all with
// the step --step (normalised units): 1 + 2d + d(d - 1)/2 exact runs. Eq. 15 of the model is the
// sum over epochs of |(r_E, r_N)|. Measured: the largest relative difference to the exact
// kernel's Eq. 15 over --candidates uniform points of the box and --near points at 0.1 sd of the
// data's optimum (Levenberg-Marquardt + Eq. 15 IRLS from the centre, sd from
// identification/uncertainty.h), the latter also with the model taken at the optimum (what a
// search fitness re-centred where the search is would use), beside the exact kernel's own floor
// (the kernel against the scalar reference on --floor of the box points; 0 where the kernel does
// not cover the data and both are the scalar reference). And what each costs per candidate: the
// exact fitness runs the strapdown over every IMU step; the model takes 2 (d + d(d + 1)/2) FMAs and
// a norm per GNSS epoch.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "identification/grade.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/local_fit.h"
#include "identification/search_fitness.h"
#include "identification/uncertainty.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"
#include "tools/tool_main.h"

namespace {

using namespace insid;
using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

// The residual vectors of `xs` (exact kernel).
std::vector<std::vector<double>> residuals(const InsIdentificationProblem& problem,
                                           const std::vector<Vec>& xs) {
  std::vector<std::vector<double>> r(xs.size());
  std::vector<double> f(xs.size());
  problem.evaluate_residual_batch(xs, r, f);
  return r;
}

// Eq. 15 of a residual vector.
double eq15(const Vec& r) {
  double f = 0.0;
  for (Eigen::Index t = 0; t + 1 < r.size(); t += 2) f += std::hypot(r[t], r[t + 1]);
  return f;
}

struct TaylorModel {
  Vec centre;  // normalised coordinates the model is taken at
  Vec r0;
  Mat J;  // m x d
  Mat H;  // m x d(d+1)/2: the d diagonal second derivatives, then the pairs i < j
  int runs = 0;

  Vec first_order(const Vec& x) const { return r0 + J * (x - centre); }
  Vec second_order(const Vec& point) const {
    const Vec x = point - centre;
    Vec r = r0 + J * x;
    const Eigen::Index d = x.size();
    for (Eigen::Index i = 0; i < d; ++i) r += 0.5 * x[i] * x[i] * H.col(i);
    Eigen::Index c = d;
    for (Eigen::Index i = 0; i < d; ++i)
      for (Eigen::Index j = i + 1; j < d; ++j, ++c) r += x[i] * x[j] * H.col(c);
    return r;
  }
};

TaylorModel taylor_at(const InsIdentificationProblem& problem, const Vec& x0, double step) {
  const int d = problem.mapping().dimension();
  std::vector<Vec> points{x0};
  for (int i = 0; i < d; ++i) {
    Vec a = x0, b = x0;
    a[i] += step;
    b[i] -= step;
    points.push_back(a);
    points.push_back(b);
  }
  for (int i = 0; i < d; ++i)
    for (int j = i + 1; j < d; ++j) {
      Vec a = x0;
      a[i] += step;
      a[j] += step;
      points.push_back(a);
    }
  const std::vector<std::vector<double>> R = residuals(problem, points);
  const auto col = [&R](std::size_t k) {
    return Eigen::Map<const Vec>(R[k].data(), static_cast<Eigen::Index>(R[k].size()));
  };
  TaylorModel model;
  model.centre = x0;
  model.runs = static_cast<int>(points.size());
  model.r0 = col(0);
  const Eigen::Index m = model.r0.size();
  model.J.resize(m, d);
  model.H.resize(m, d * (d + 1) / 2);
  for (int i = 0; i < d; ++i) {
    const auto a = col(1 + 2 * static_cast<std::size_t>(i)),
               b = col(2 + 2 * static_cast<std::size_t>(i));
    model.J.col(i) = (a - b) / (2.0 * step);
    model.H.col(i) = (a + b - 2.0 * model.r0) / (step * step);
  }
  std::size_t k = 1 + 2 * static_cast<std::size_t>(d);
  int c = d;
  for (int i = 0; i < d; ++i)
    for (int j = i + 1; j < d; ++j, ++k, ++c)
      model.H.col(c) = (col(k) - col(1 + 2 * static_cast<std::size_t>(i)) -
                        col(1 + 2 * static_cast<std::size_t>(j)) + model.r0) /
                       (step * step);
  return model;
}

int fitness_surrogate_study_main(int argc, char** argv) {
  CLI::App app(
      "insid-fitness-surrogate-study: a Taylor model of the residuals against the exact Eq. 15",
      "insid-fitness-surrogate-study");
  std::string data_dir, preset = "paper", grade = "nav", attitude = "auto", jsonl;
  double flight_s = 0.0, window_s = 0.0, step = 0.02, node_spacing_s = 0.2;
  int candidates = 1000, near = 100, floor_points = 5, threads = 0;
  std::uint64_t seed = 1;
  std::vector<std::string> estimate;
  app.add_option("--data", data_dir, "dataset directory (default: simulate --preset)");
  app.add_option("--preset", preset, "scenario simulated without --data")->capture_default_str();
  app.add_option("--flight-s", flight_s, "simulated flight after the alignment (0: the preset's)")
      ->check(tools::finite_number())
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--grade", grade, "nav | tactical | mems: noise and parameter sigmas")
      ->capture_default_str();
  app.add_option("--window-s", window_s, "fitness window (s)")
      ->capture_default_str()
      ->check(tools::finite_number())
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--initial-attitude", attitude,
                 "auto (gyrocompass for nav, level+heading otherwise) or a mode of insid identify")
      ->capture_default_str();
  app.add_option("--estimate", estimate, "parameters (default: the grade's identify default)");
  app.add_option("--candidates", candidates, "uniform points of the box")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  app.add_option("--near", near, "points at 0.1 sd of the optimum")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  app.add_option("--floor", floor_points, "box points also run through the scalar reference")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--step", step, "finite-difference step (normalised box units)")
      ->capture_default_str()
      ->check(tools::finite_number())
      ->check(CLI::Range(1e-6, 0.5));
  app.add_option("--node-spacing-s", node_spacing_s,
                 "the fast search fitness's time between nodes (identification/search_fitness.h)")
      ->capture_default_str()
      ->check(tools::finite_number())
      ->check(CLI::Range(1e-6, 1e6));
  app.add_option("--seed", seed, "simulation and candidate seed")->capture_default_str();
  app.add_option("--threads", threads, "threads (0 = all)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4096));
  app.add_option("--jsonl", jsonl, "append one JSON line with the figures");
  tools::parse(app, argc, argv);
  const SensorGrade& g =
      cli::parse_option("--grade", [&] { return std::cref(sensor_grade(grade)); });
  NavigationOptions options;
  options.window_s = window_s;
  options.initial_attitude.mode = attitude == "auto"
                                      ? (grade == "nav" ? InitialAttitudeMode::kGyrocompass
                                                        : InitialAttitudeMode::kLevelHeading)
                                      : cli::parse_option("--initial-attitude", [&] {
                                          return initial_attitude_mode_from_string(attitude);
                                        });
  const std::vector<EstimatedParameter> estimated =
      cli::parse_option("--estimate", [&] { return identify_parameters(g, estimate); });
  options.initial_attitude.gyro_bias_allowance_rad_s = gyro_bias_allowance_rad_s(estimated);

  std::shared_ptr<const Dataset> dataset;
  std::string source;
  if (!data_dir.empty()) {
    dataset = std::make_shared<const Dataset>(load_dataset(data_dir));
    source = data_dir;
  } else {
    scenarios::ScenarioConfig cfg =
        cli::parse_option("--preset", [&] { return scenarios::preset_scenario(preset); });
    if (flight_s > 0.0) cfg.flight_s = flight_s;
    cfg.noise = scenarios::noise_grade(grade);
    cfg.seed = seed;
    dataset = std::make_shared<const Dataset>(scenarios::simulate(cfg));
    source = "preset " + preset + " (" + grade + " noise, seed " + std::to_string(seed) + ")";
  }
  const auto navigation = std::make_shared<const NavigationProblem>(dataset, options);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
  evaluator.num_threads = threads;
  const ParameterMapping mapping(estimated);
  const InsIdentificationProblem problem(navigation, mapping, FitnessKind::kEq15, evaluator);
  const int d = mapping.dimension();

  const TaylorModel model = taylor_at(problem, Vec::Zero(d), step);

  // The data's optimum and its sd (sigma units), for the points near it.
  const LocalFitResult optimum = local_fit(problem, Vec::Zero(d));
  UncertaintyOptions uo;
  uo.replicas = 30;
  uo.criterion = UncertaintyCriterion::kEq15;
  uo.threads = threads;
  const UncertaintyReport u = estimate_uncertainty(problem, optimum.value_sigma, uo);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> normal;
  std::vector<Vec> box, around;
  for (int n = 0; n < candidates; ++n) {
    Vec x(d);
    for (int i = 0; i < d; ++i) x[i] = uniform(rng);
    box.push_back(x);
  }
  for (int n = 0; n < near; ++n) {
    Vec dir(d);
    for (int i = 0; i < d; ++i) dir[i] = normal(rng);
    dir.normalize();
    Vec s = optimum.value_sigma;
    for (int i = 0; i < d; ++i) {
      const ParameterUncertainty& p = u.parameters[static_cast<std::size_t>(i)];
      const double sd_sigma = p.sd_si ? *p.sd_si / p.sigma_si : 0.0;
      s[i] += 0.1 * sd_sigma * dir[i];
    }
    around.push_back(mapping.from_sigma(s));
  }
  struct Worst {
    double first = 0.0, second = 0.0;
  };
  const auto compare = [&](const std::vector<Vec>& xs, const TaylorModel& taylor) {
    std::vector<double> f(xs.size());
    problem.evaluate_batch(xs, f);
    Worst w;
    for (std::size_t n = 0; n < xs.size(); ++n) {
      w.first = std::max(w.first, std::abs(eq15(taylor.first_order(xs[n])) - f[n]) / f[n]);
      w.second = std::max(w.second, std::abs(eq15(taylor.second_order(xs[n])) - f[n]) / f[n]);
    }
    return w;
  };
  const Worst in_box = compare(box, model);
  // The fast search fitness itself (the model at the centre, interpolated between nodes).
  FastFitnessOptions fo;
  fo.step = step;
  fo.node_spacing_s = node_spacing_s;
  const FastFitness fast(problem, fo);
  const auto compare_fast = [&](const std::vector<Vec>& xs) {
    std::vector<double> f(xs.size()), f_fast(xs.size());
    problem.evaluate_batch(xs, f);
    fast.evaluate(xs, f_fast, evaluator.threads());
    double worst = 0.0;
    for (std::size_t n = 0; n < xs.size(); ++n)
      worst = std::max(worst, std::abs(f_fast[n] - f[n]) / f[n]);
    return worst;
  };
  const double fast_box = compare_fast(box);
  const double fast_near = around.empty() ? 0.0 : compare_fast(around);
  const Worst near_optimum = around.empty() ? Worst{} : compare(around, model);
  // What a search fitness re-centred where the search is would use: the model at the optimum.
  const TaylorModel at_optimum = taylor_at(problem, optimum.x, step);
  const Worst near_by_optimum_model = around.empty() ? Worst{} : compare(around, at_optimum);
  double floor = 0.0;
  {
    const int k = std::min<int>(floor_points, candidates);
    std::vector<Vec> xs(box.begin(), box.begin() + k);
    std::vector<double> f(xs.size());
    problem.evaluate_batch(xs, f);
    for (int n = 0; n < k; ++n) {
      const double reference = navigation->fitness(mapping.to_errors(xs[n]), FitnessKind::kEq15);
      floor = std::max(floor, std::abs(f[n] - reference) / reference);
    }
  }
  const double epochs = static_cast<double>(navigation->num_epochs());
  const double steps = static_cast<double>(navigation->num_steps());
  const double model_fmas = 2.0 * epochs * (d + d * (d + 1) / 2.0);

  nlohmann::json j = {
      {"data", source},
      {"grade", grade},
      {"window_s", window_s},
      {"initial_attitude", to_string(options.initial_attitude.mode)},
      {"estimated", nlohmann::json::array()},
      {"imu_steps", steps},
      {"gnss_epochs", epochs},
      {"exact_runs_to_build", model.runs},
      {"step", step},
      {"candidates", candidates},
      {"near", near},
      {"max_rel_diff_first_order_box", in_box.first},
      {"max_rel_diff_second_order_box", in_box.second},
      {"max_rel_diff_first_order_near", near_optimum.first},
      {"max_rel_diff_second_order_near", near_optimum.second},
      {"max_rel_diff_first_order_near_model_at_optimum", near_by_optimum_model.first},
      {"max_rel_diff_second_order_near_model_at_optimum", near_by_optimum_model.second},
      {"fast_fitness", fast.to_json()},
      {"max_rel_diff_fast_box", fast_box},
      {"max_rel_diff_fast_near", fast_near},
      {"kernel_supported", problem.uses_batched_kernel()},
      {"kernel_floor_vs_scalar", floor},
      {"floor_points", std::min(floor_points, candidates)},
      {"second_order_fmas_per_candidate", model_fmas},
      {"second_order_fmas_per_imu_step", model_fmas / steps}};
  for (const EstimatedParameter& p : estimated) j["estimated"].push_back(p.name);
  std::cout << "| " << source << " | " << grade << " | " << window_s << " | " << d << " | " << steps
            << " | " << epochs << " | " << in_box.first << " | " << in_box.second << " | "
            << near_optimum.first << " | " << near_optimum.second << " | "
            << near_by_optimum_model.second << " | " << floor << " | " << model_fmas / steps
            << " | " << node_spacing_s << " | " << fast_box << " | " << fast_near << " |\n";
  if (!jsonl.empty()) std::ofstream(jsonl, std::ios::app) << j.dump() << "\n";
  return cli::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-fitness-surrogate-study",
                           [&] { return fitness_surrogate_study_main(argc, argv); });
}
