// insid-kernel-budget: how exactly a fewer-operations fitness must reproduce the exact kernel
// (results/perf/fewer-ops/README.md). For each scenario x grade (x window):
//
//  1. The exact kernel's own floor: Eq. 15 of random candidates in the grade's box, on the
//     kernel's FMA path (avx512, else avx2) and on its unfused baseline path, and the scalar
//     reference (NavigationProblem::fitness). Two equally exact arithmetics differ by rounding
//     only; their difference is what no reorganisation can beat.
//  2. The sensitivity of Eq. 15 to a tiny systematic error of the kind an approximation makes:
//     a constant angular-rate error (a gyro bias change of 1e-12 rad/s on x, y or z) and a
//     constant specific-force error (an accelerometer bias change of 1e-9 m/s^2), each at two
//     sizes (delta, 2 delta: the change must double). From the smallest change per unit over
//     candidates and axes: the systematic error per IMU step (rad, m/s) that moves Eq. 15 by the
//     tolerance (1e-7 relative at navigation grade, 1e-5 at MEMS grade: the target of a
//     fewer-operations kernel).
//
//  3. The size of the first approximation a preintegrated kernel makes: the body rotation over an
//     interval of N IMU steps taken to first order in the gyro bias. For the box corner b (4
//     sigma on each axis) the exact rotation of the bias-compensated, coning-corrected steps
//     (as the kernel forms them) is compared with the uncompensated one: eps(b) = log(B(0)^-1
//     B(b)); its part even in b, (eps(b) + eps(-b)) / 2, is what a first-order Jacobian leaves
//     out (second order and up). Largest over the flight's intervals, per interval and per step.
//
// Writes OUT/budget.json and prints one line per case.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "base/output_dir.h"
#include "data/grade_table.h"
#include "kernel/batch_fitness.h"
#include "kernel/cpu_path.h"
#include "model/rotation.h"
#include "model/sensor_errors.h"
#include "nav/fitness.h"
#include "nav/mechanization.h"
#include "scenarios/scenario.h"
#include "tools/tool_main.h"

namespace {

using json = nlohmann::json;
using namespace insid;

struct Case {
  std::string preset, grade;
  double window_s = 0.0;
};

// Random candidates in the grade's box: the paper's four parameters within +-4 sigma, plus
// (every other candidate) the z biases; the first candidate is the zero-error one.
std::vector<SensorErrors> box_candidates(const GradeFigures& g, int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  std::vector<SensorErrors> out(1);
  for (int i = 1; i < n; ++i) {
    SensorErrors c;
    c.accel.bias.x() = u(rng) * g.accel_bias_mps2;
    c.accel.bias.y() = u(rng) * g.accel_bias_mps2;
    c.gyro.bias.x() = u(rng) * g.gyro_bias_rad_s;
    c.gyro.bias.y() = u(rng) * g.gyro_bias_rad_s;
    if (i % 2 == 0) {
      c.accel.bias.z() = u(rng) * g.accel_bias_mps2;
      c.gyro.bias.z() = u(rng) * g.gyro_bias_rad_s;
    }
    out.push_back(c);
  }
  return out;
}

// The body rotation of IMU steps [begin, end) with the gyro bias b removed, coning-corrected
// as the kernel and Strapdown do (two-sample form, the measured steps' divisor).
Eigen::Quaterniond body_rotation(const Dataset& ds, std::size_t begin, std::size_t end,
                                 const Eigen::Vector3d& b_rad_s) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (std::size_t k = begin; k < end; ++k) {
    const double dt = ds.imu[k].t_s - ds.imu[k - 1].t_s;
    const double dt_prev = k >= 2 ? ds.imu[k - 1].t_s - ds.imu[k - 2].t_s : dt;
    const Eigen::Vector3d dth = ds.imu[k].dtheta_b_rad - b_rad_s * dt;
    const Eigen::Vector3d dth_prev = ds.imu[k - 1].dtheta_b_rad - b_rad_s * dt_prev;
    const Eigen::Vector3d phi = dth + dth_prev.cross(dth) / two_sample_divisor(dt_prev, dt);
    q = q * quat_from_rotation_vector(phi);
  }
  return q;
}

// Item 3: the largest even-in-b part of log(B(0)^-1 B(b)) over intervals of n steps.
double largest_second_order_rotation(const Dataset& ds, std::size_t first, std::size_t n,
                                     const Eigen::Vector3d& b_rad_s) {
  double worst = 0.0;
  for (std::size_t k = first; k + n <= ds.imu.size(); k += n) {
    const Eigen::Quaterniond q0 = body_rotation(ds, k, k + n, Eigen::Vector3d::Zero());
    const Eigen::Vector3d plus =
        rotation_vector_from_quat(q0.conjugate() * body_rotation(ds, k, k + n, b_rad_s));
    const Eigen::Vector3d minus =
        rotation_vector_from_quat(q0.conjugate() * body_rotation(ds, k, k + n, -b_rad_s));
    worst = std::max(worst, (0.5 * (plus + minus)).norm());
  }
  return worst;
}

double worst_relative(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / std::abs(b[i]));
  return worst;
}

json run_case(const Case& cs, double flight_s, int n, std::uint64_t seed, int threads) {
  scenarios::ScenarioOverrides o;
  o.seed = seed;
  if (cs.grade != "nav") o.grade = cs.grade;
  if (flight_s > 0.0) o.flight_s = flight_s;
  auto ds = std::make_shared<const Dataset>(scenarios::simulate_preset(cs.preset, o));
  NavigationOptions options;
  options.window_s = cs.window_s;
  // MEMS gyros cannot gyrocompass: level + the heading from the GNSS course, as users run them.
  if (cs.grade == "mems") options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  auto nav = std::make_shared<const NavigationProblem>(ds, options);
  const BatchFitness kernel(nav);
  if (!kernel.supported()) throw std::runtime_error(kernel.unsupported_reason());
  const GradeFigures& g = grade_figures(cs.grade);
  const std::vector<SensorErrors> pool = box_candidates(g, n, seed);
  const double tolerance = cs.grade == "mems" ? 1e-5 : 1e-7;

  // 1. The floor: the FMA path against the unfused one and the scalar reference.
  std::string fma_path;
  for (const char* p : {"avx512", "avx2"})
    if (fma_path.empty() && cpu_runs_path(p)) fma_path = p;
  const std::vector<double> unfused = kernel.fitness(pool, FitnessKind::kEq15, threads, "baseline");
  std::vector<double> scalar;
  for (const SensorErrors& c : pool) scalar.push_back(nav->fitness(c));
  json floor = {{"baseline_vs_scalar", worst_relative(unfused, scalar)}};
  if (!fma_path.empty()) {
    const std::vector<double> fused = kernel.fitness(pool, FitnessKind::kEq15, threads, fma_path);
    floor["fma_path"] = fma_path;
    floor["fma_vs_baseline"] = worst_relative(fused, unfused);
  }

  // 2. Sensitivities: relative change of Eq. 15 per unit systematic error, the largest over
  // candidates and axes (the tightest budget), from perturbations well above the floor and
  // checked for linearity.
  const double dt_s = 1.0 / ds->meta.imu_rate_hz;
  // Sizes that move Eq. 15 by ~1e-8..1e-5 relative on these flights: far above the floor,
  // small enough to stay linear at MEMS grade too (checked: the change at 2 delta).
  const double d_gyro = 1e-12, d_accel = 1e-9;
  std::vector<SensorErrors> perturbed;
  for (const SensorErrors& c : pool)
    for (int kind = 0; kind < 2; ++kind)
      for (int axis = 0; axis < 3; ++axis)
        for (double k : {1.0, 2.0}) {
          SensorErrors x = c;
          if (kind == 0)
            x.gyro.bias[axis] += k * d_gyro;
          else
            x.accel.bias[axis] += k * d_accel;
          perturbed.push_back(x);
        }
  const std::vector<double> fp = kernel.fitness(perturbed, FitnessKind::kEq15, threads, "baseline");
  double max_per_gyro = 0.0, max_per_accel = 0.0, gyro_linearity = 0.0, accel_linearity = 0.0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < pool.size(); ++i)
    for (int kind = 0; kind < 2; ++kind)
      for (int axis = 0; axis < 3; ++axis) {
        const double r1 = (fp[at] - unfused[i]) / unfused[i];
        const double r2 = (fp[at + 1] - unfused[i]) / unfused[i];
        at += 2;
        const double per_unit = std::abs(r1) / (kind == 0 ? d_gyro : d_accel);
        double& max_per_unit = kind == 0 ? max_per_gyro : max_per_accel;
        if (per_unit > max_per_unit) {
          max_per_unit = per_unit;
          // r2 / r1 = 2 where the change is linear (for the entries that set the budget).
          (kind == 0 ? gyro_linearity : accel_linearity) = r2 / r1;
        }
      }
  const double gyro_budget = tolerance / max_per_gyro, accel_budget = tolerance / max_per_accel;

  // 3. The first-order body rotation's leftover over intervals of 8 and 10 steps (the box
  // corner; the navigation's first step onwards).
  const Eigen::Vector3d corner = Eigen::Vector3d::Constant(4.0 * g.gyro_bias_rad_s);
  const std::size_t first = std::max<std::size_t>(nav->nav_begin(), 2);
  json second_order = json::array();
  for (std::size_t steps : {8, 10}) {
    const double per_interval = largest_second_order_rotation(*ds, first, steps, corner);
    second_order.push_back({{"steps", steps},
                            {"largest_rad_per_interval", per_interval},
                            {"per_step_rad", per_interval / static_cast<double>(steps)},
                            {"share_of_budget", per_interval / steps / (gyro_budget * dt_s)}});
  }
  json out = {{"preset", cs.preset},
              {"grade", cs.grade},
              {"window_s", cs.window_s},
              {"flight_s", ds->imu.back().t_s - ds->imu.front().t_s},
              {"imu_rate_hz", ds->meta.imu_rate_hz},
              {"candidates", n},
              {"tolerance_relative", tolerance},
              {"floor", floor},
              {"relative_change_per_rad_s", max_per_gyro},
              {"relative_change_per_mps2", max_per_accel},
              // The same slopes per sigma of the grade's bias box: how far (in sigma) a
              // candidate must move to change Eq. 15 by the tolerance.
              {"relative_change_per_gyro_bias_sigma", max_per_gyro * g.gyro_bias_rad_s},
              {"relative_change_per_accel_bias_sigma", max_per_accel * g.accel_bias_mps2},
              {"change_ratio_at_twice_the_rate_error", gyro_linearity},
              {"change_ratio_at_twice_the_force_error", accel_linearity},
              {"budget_rate_error_rad_s", gyro_budget},
              {"budget_rate_error_rad_per_step", gyro_budget * dt_s},
              {"budget_force_error_mps2", accel_budget},
              {"budget_force_error_mps_per_step", accel_budget * dt_s},
              {"first_order_body_rotation_leftover", second_order}};
  std::printf(
      "%s %s W=%g: floor FMA-vs-unfused %.2e, unfused-vs-scalar %.2e; tolerance %.0e <- rate "
      "error %.2e rad/s (%.2e rad per step), force error %.2e m/s^2 (%.2e m/s per step); "
      "change at 2 delta / at delta %.3f, %.3f (2 = linear)\n",
      cs.preset.c_str(), cs.grade.c_str(), cs.window_s,
      floor.value("fma_vs_baseline", std::nan("")), floor["baseline_vs_scalar"].get<double>(),
      tolerance, gyro_budget, gyro_budget * dt_s, accel_budget, accel_budget * dt_s, gyro_linearity,
      accel_linearity);
  for (const json& so : second_order)
    std::printf(
        "  body rotation to first order in b over %d steps leaves %.2e rad (%.2e per step, "
        "%.2g of the budget)\n",
        so["steps"].get<int>(), so["largest_rad_per_interval"].get<double>(),
        so["per_step_rad"].get<double>(), so["share_of_budget"].get<double>());
  std::fflush(stdout);
  return out;
}

int kernel_budget_main(int argc, char** argv) {
  CLI::App app{
      "How exactly a fewer-operations fitness must reproduce the exact kernel: its rounding floor "
      "and the systematic errors per IMU step that move Eq. 15 by the tolerance.",
      "insid-kernel-budget"};
  std::vector<std::string> presets = {"paper", "rich", "racetrack"};
  std::vector<std::string> grades = {"nav", "mems"};
  double flight_s = 0.0, mems_window_s = 10.0;
  int candidates = 16, threads = 2;
  std::uint64_t seed = 7;
  std::string out = "results/perf/fewer-ops";
  app.add_option("--presets", presets, "scenario presets")->delimiter(',')->capture_default_str();
  app.add_option("--grades", grades, "nav (W = 0, tolerance 1e-7) and/or mems (tolerance 1e-5)")
      ->delimiter(',')
      ->check(CLI::IsMember({"nav", "mems"}))
      ->capture_default_str();
  app.add_option("--flight-s", flight_s, "flight after the alignment (default: the preset's)")
      ->check(tools::finite_number())
      ->check(CLI::NonNegativeNumber);
  app.add_option("--mems-window-s", mems_window_s, "windowed fitness at MEMS grade (0: none)")
      ->check(tools::finite_number())
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--candidates", candidates, "random candidates in the box (the first is zero)")
      ->check(CLI::Range(2, 1000))
      ->capture_default_str();
  app.add_option("--seed", seed, "noise and candidate seed")->capture_default_str();
  app.add_option("--threads", threads, "threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--out", out, "output directory (budget.json)")->capture_default_str();
  WriteOptions write;
  app.add_flag("--force", write.replace_foreign,
               "replace a budget.json insid did not write (e.g. the committed one after a clone)");
  tools::parse(app, argc, argv);
  for (const std::string& p : presets)
    cli::parse_option("--presets", [&] { (void)scenarios::preset_scenario(p); });

  // The output is checked before the work (a link, a directory or a file insid did not write
  // there is refused) and written atomically after it.
  const std::filesystem::path file = std::filesystem::path(out) / "budget.json";
  check_file_writable(file, write);

  json cases = json::array();
  for (const std::string& p : presets)
    for (const std::string& g : grades)
      cases.push_back(
          run_case({p, g, g == "mems" ? mems_window_s : 0.0}, flight_s, candidates, seed, threads));
  std::filesystem::create_directories(out);
  write_file_atomic(file,
                    json{{"program", "insid-kernel-budget"},
                         {"cpu_path", cpu_path_description()},
                         {"cases", cases}}
                            .dump(2) +
                        "\n",
                    write);
  std::cerr << "insid-kernel-budget: wrote " << file.string() << '\n';
  return cli::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-kernel-budget", [&] { return kernel_budget_main(argc, argv); });
}
