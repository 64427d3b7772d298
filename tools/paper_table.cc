// insid-paper-table: reproduces the paper's Sec. 3.1 table (Eq. 15 with exact compensation and
// with each of the five error cases) on the `paper` preset, and writes
//   OUT/table.json                      the numbers, the paper's, the ratios, the configuration
//   OUT/velocity_error_<case>.csv       INS-minus-GNSS velocity error series (for the figures)
// scripts/paper_table_plots.py turns the CSVs into Figures 3-8.
//
// Each case is a residual sensor error delta (sigma units, [dA0x, dA0y, dD0x, dD0y]): the data
// carry the preset's injected errors e, the navigation compensates with e - delta. "exact" is
// delta = 0; "all four" is delta = e, i.e. the raw data (the starting point of Sec. 3.2).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "insid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)
#include "nav/fitness.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"
#include "tools/tool_main.h"

namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;
using namespace insid;
using namespace insid::scenarios;

constexpr std::array<const char*, 4> kParams = {"accel_bias_x", "accel_bias_y", "gyro_bias_x",
                                                "gyro_bias_y"};

struct Case {
  std::string id, label, figure;
  std::array<double, 4> delta_sigma;  // residual error after compensation
  double paper_fitness;
};

const std::vector<Case>& cases() {
  static const std::vector<Case> k = {
      {"exact", "exact compensation", "Figure 3", {0, 0, 0, 0}, 1.0e3},
      {"dA0x", "dA0x = -2 sigma_A", "Figure 4", {-2, 0, 0, 0}, 3.032e5},
      {"dA0y", "dA0y = 1.5 sigma_A", "Figure 5", {0, 1.5, 0, 0}, 1.959e5},
      {"dD0x", "dD0x = 2 sigma_D", "Figure 6", {0, 0, 2, 0}, 4.135e5},
      {"dD0y", "dD0y = -1.5 sigma_D", "Figure 7", {0, 0, 0, -1.5}, 3.116e5},
      {"all", "all four", "Figure 8", {-2, 1.5, 2, -1.5}, 8.552e5},
  };
  return k;
}

int paper_table_main(int argc, char** argv) {
  CLI::App app{"Reproduce the paper's Sec. 3.1 table (Eq. 15 fitness for the five error cases).",
               "insid-paper-table"};
  std::string out = "results/paper-table";
  std::string preset = "paper";
  std::string config_file;
  std::string alignment = "per-candidate";
  std::string grade;
  double flight_s = 0.0;
  double series_rate_hz = 0.2;
  std::uint64_t seed = 1;
  int timing_repeats = 3;
  app.add_option("--out", out, "output directory")->capture_default_str();
  app.add_option("--preset", preset, "scenario preset")->capture_default_str();
  app.add_option("--config", config_file, "scenario JSON file instead of a preset");
  app.add_option("--alignment", alignment, "per-candidate | fixed")->capture_default_str();
  app.add_option("--grade", grade, "noise grade (default: the preset's)");
  app.add_option("--flight-s", flight_s, "flight after the alignment (default: the preset's)");
  app.add_option("--seed", seed, "random seed")->capture_default_str();
  app.add_option("--series-rate-hz", series_rate_hz, "rate of the velocity-error CSVs")
      ->capture_default_str();
  app.add_option("--timing-repeats", timing_repeats, "fitness evaluations timed")
      ->capture_default_str();
  tools::parse(app, argc, argv);
  // Names checked before any work (a bad one is a usage error).
  NavigationOptions options;
  options.alignment =
      cli::parse_option("--alignment", [&] { return alignment_mode_from_string(alignment); });
  if (!grade.empty()) cli::parse_option("--grade", [&] { return noise_grade(grade); });
  if (config_file.empty()) cli::parse_option("--preset", [&] { return preset_scenario(preset); });

  ScenarioOverrides overrides;
  overrides.seed = seed;
  if (!grade.empty()) overrides.grade = grade;
  if (flight_s > 0) overrides.flight_s = flight_s;
  const ScenarioConfig cfg = with_overrides(
      config_file.empty() ? preset_scenario(preset) : load_scenario_file(config_file), overrides);
  if (!config_file.empty()) preset = cfg.name;
  const ScenarioPlan plan = plan_scenario(cfg);
  std::fprintf(stderr,
               "simulating preset '%s': %.0f s alignment + %.0f s flight, %zu IMU rows, "
               "%zu GNSS rows ...\n",
               preset.c_str(), cfg.align_s, plan.flight_s, plan.num_imu_steps, plan.num_gnss);
  const auto t_sim0 = std::chrono::steady_clock::now();
  auto ds = std::make_shared<const Dataset>(simulate(cfg, plan));
  const double sim_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_sim0).count();

  const NavigationProblem problem(ds, options);

  // GNSS epoch times of the residuals (same selection as NavigationProblem).
  std::vector<double> epoch_t;
  const double t_nav0 = problem.nav_start_t_s(), t_last = ds->imu.back().t_s;
  for (const GnssSample& g : ds->gnss)
    if (g.t_s > t_nav0 + 1e-9 && g.t_s <= t_last + 1e-9) epoch_t.push_back(g.t_s);

  fs::create_directories(out);
  json table;
  table["schema"] = "insid-paper-table/1";
  table["git_revision"] = INSID_GIT_REVISION;
  table["preset"] = preset;
  table["config"] = scenario_to_json(cfg);
  table["alignment"] = to_string(options.alignment);
  table["flight_s"] = plan.flight_s;
  table["gnss_rate_hz"] = cfg.gnss_rate_hz;
  table["epochs_compared"] = problem.num_epochs();
  table["simulation_wall_s"] = sim_s;
  table["case_definition"] =
      "data carry the injected errors e; the navigation compensates with e - delta; delta is "
      "the residual error of the case, sigma units [dA0x, dA0y, dD0x, dD0y]";
  json rows = json::array();

  for (const Case& c : cases()) {
    SensorErrors candidate = cfg.injected;
    for (int i = 0; i < 4; ++i)
      add_effect(candidate, kParams[i], -c.delta_sigma[i] * effect_info(kParams[i]).sigma);
    std::vector<double> r;
    problem.residuals(candidate, r);
    double fitness = 0, max_dv = 0, sum_sq = 0;
    for (std::size_t e = 0; e + 1 < r.size(); e += 2) {
      const double d = std::hypot(r[e], r[e + 1]);
      fitness += d;  // Eq. 15
      max_dv = std::max(max_dv, d);
      sum_sq += d * d;
    }
    const double n = static_cast<double>(r.size() / 2);
    // Velocity-error series for the figure, decimated.
    const std::size_t step = std::max<std::size_t>(
        1, static_cast<std::size_t>(std::llround(cfg.gnss_rate_hz / series_rate_hz)));
    std::ofstream csv(fs::path(out) / ("velocity_error_" + c.id + ".csv"));
    csv << "t_s,dvE_mps,dvN_mps\n";
    char line[128];
    for (std::size_t e = 0; e < r.size() / 2; e += step) {
      std::snprintf(line, sizeof line, "%.2f,%.6e,%.6e\n", epoch_t[e], r[2 * e], r[2 * e + 1]);
      csv << line;
    }
    if (!csv) throw std::runtime_error("cannot write the velocity-error CSV under " + out);
    json row = {{"id", c.id},
                {"label", c.label},
                {"figure", c.figure},
                {"delta_sigma", c.delta_sigma},
                {"fitness_eq15", fitness},
                {"paper_fitness", c.paper_fitness},
                {"ratio_to_paper", fitness / c.paper_fitness},
                {"mean_dv_mps", fitness / n},
                {"rms_dv_mps", std::sqrt(sum_sq / n)},
                {"max_dv_mps", max_dv}};
    rows.push_back(row);
    std::fprintf(stderr, "%-22s fitness %.4g  (paper %.4g, ratio %.2f)  mean |dv| %.3g m/s\n",
                 c.label.c_str(), fitness, c.paper_fitness, fitness / c.paper_fitness, fitness / n);
  }
  table["cases"] = rows;
  // Order of the four single-error cases, by fitness, ours vs the paper's.
  std::vector<std::pair<double, std::string>> ours, paper;
  for (const json& row : rows) {
    const std::string id = row["id"];
    if (id == "exact" || id == "all") continue;
    ours.push_back({row["fitness_eq15"].get<double>(), id});
    paper.push_back({row["paper_fitness"].get<double>(), id});
  }
  std::sort(ours.rbegin(), ours.rend());
  std::sort(paper.rbegin(), paper.rend());
  json order_ours = json::array(), order_paper = json::array();
  for (const auto& o : ours) order_ours.push_back(o.second);
  for (const auto& p : paper) order_paper.push_back(p.second);
  table["single_case_order"] = order_ours;
  table["paper_single_case_order"] = order_paper;
  table["order_matches_paper"] = order_ours == order_paper;
  bool within2 = true;
  for (const json& row : rows) {
    const double q = row["ratio_to_paper"].get<double>();
    within2 = within2 && q >= 0.5 && q <= 2.0;
  }
  table["all_within_factor_2"] = within2;

  // Cost of one Eq. 15 evaluation (NavigationProblem::fitness: alignment + full run).
  std::vector<double> times;
  for (int i = 0; i < std::max(1, timing_repeats); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    volatile double f = problem.fitness(cfg.injected);
    (void)f;
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  table["fitness_eval_s"] = {{"min", times.front()},
                             {"median", times[times.size() / 2]},
                             {"repeats", times.size()},
                             {"imu_steps", problem.num_steps()},
                             {"ns_per_step", 1e9 * times.front() / problem.num_steps()}};
  std::fprintf(stderr, "one fitness evaluation: %.3f s (%zu IMU steps, %.0f ns/step)\n",
               times.front(), problem.num_steps(), 1e9 * times.front() / problem.num_steps());

  write_file_atomic(fs::path(out) / "table.json", table.dump(2) + "\n");
  std::cout << (fs::path(out) / "table.json").string() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-paper-table", [&] { return paper_table_main(argc, argv); });
}
