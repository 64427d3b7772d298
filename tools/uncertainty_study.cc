// Calibration study of the identification uncertainty (results/uncertainty/): over
// noise seeds of a simulated flight, does the 95 % interval of each parameter cover the injected
// value, and is |error| / sd about 1 (RMS)? For LM (the least-squares optimum, the point the sd
// describes), EKF-RTS (its estimate with the same sd, and the filter's own smoothed sd) and any
// other registered algorithm. Markdown table on stdout, one JSON line per run with --jsonl.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "identification/ekf_rts.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/uncertainty.h"
#include "optimizers/registry.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"
#include "tools/tool_main.h"

namespace {

using namespace insid;
constexpr double kZ95 = 1.959963984540054;

struct Tally {
  int runs = 0, covered = 0, flagged = 0;
  double z2 = 0.0;
  void add(double err, double sd, bool flags) {
    ++runs;
    covered += std::abs(err) <= kZ95 * sd;
    z2 += err * err / (sd * sd);
    flagged += flags;
  }
};

int uncertainty_study_main(int argc, char** argv) {
  CLI::App app("insid-uncertainty-study: coverage of the identification's 95 % intervals",
               "insid-uncertainty-study");
  std::string preset = "rich", grade = "nav", jsonl;
  double flight_s = 120.0;
  int seeds = 50, replicas = 100, evaluations = 200;
  std::vector<std::string> algorithms = {"lm", "ekf-rts"};
  app.add_option("--preset", preset)->capture_default_str();
  app.add_option("--flight-s", flight_s)->capture_default_str();
  app.add_option("--grade", grade)->capture_default_str();
  app.add_option("--seeds", seeds)->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--replicas", replicas)->capture_default_str()->check(CLI::Range(10, 100000));
  app.add_option("--evaluations", evaluations, "budget of the optimizers")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000000));
  app.add_option("--algo", algorithms, "algorithms")->capture_default_str();
  app.add_option("--jsonl", jsonl, "one JSON line per run");
  tools::parse(app, argc, argv);
  // Names checked before any work (a bad one is a usage error).
  cli::parse_option("--preset", [&] { return scenarios::preset_scenario(preset); });
  cli::parse_option("--grade", [&] { return scenarios::noise_grade(grade); });
  for (const std::string& algo : algorithms)
    cli::parse_option("--algo", [&] { tools::check_algorithm(algo); });

  std::ofstream jout;
  if (!jsonl.empty()) jout.open(jsonl);
  const std::vector<std::string> names = {"accel_bias_x", "accel_bias_y", "gyro_bias_x",
                                          "gyro_bias_y"};
  // tally[algorithm + variant][parameter]
  std::map<std::string, std::vector<Tally>> tally;
  std::map<std::string, double> wall;
  for (int seed = 1; seed <= seeds; ++seed) {
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario(preset);
    cfg.flight_s = flight_s;
    cfg.noise = scenarios::noise_grade(grade);
    cfg.seed = static_cast<std::uint64_t>(seed);
    const auto dataset = std::make_shared<const Dataset>(scenarios::simulate(cfg));
    const auto navigation = std::make_shared<const NavigationProblem>(dataset);
    opt::EvaluatorOptions evaluator;
    evaluator.parallelism = opt::Parallelism::kOpenMP;
    const ParameterMapping mapping(EstimatedParameter::paper_four());
    const InsIdentificationProblem problem(navigation, mapping, FitnessKind::kEq15, evaluator);
    Eigen::VectorXd truth(4);
    for (int k = 0; k < 4; ++k) {
      const auto it = dataset->meta.injected->find(names[static_cast<std::size_t>(k)]);
      truth[k] = (it == dataset->meta.injected->end() ? 0.0 : it->second) /
                 mapping.parameters()[static_cast<std::size_t>(k)].sigma;
    }
    for (const std::string& algo : algorithms) {
      opt::RunConfig config;
      config.seed = static_cast<std::uint64_t>(seed);
      config.max_iterations = 0;
      config.max_evaluations = evaluations;
      auto optimizer = opt::make_optimizer(algo, problem.bounds(), config);
      const opt::Result& result = opt::run(*optimizer, problem);
      const Eigen::VectorXd est = mapping.to_sigma(result.best_x);
      UncertaintyOptions uo;
      uo.replicas = replicas;
      uo.criterion = criterion_for_algorithm(algo);
      const UncertaintyReport rep = estimate_uncertainty(problem, est, uo);
      wall[algo] += rep.wall_s;
      auto& t = tally[algo];
      t.resize(4);
      nlohmann::json line = {
          {"seed", seed}, {"algorithm", algo}, {"preset", preset}, {"flight_s", flight_s}};
      add_uncertainty_json(line, rep);
      line["truth_in_sigma_units"] = std::vector<double>(truth.data(), truth.data() + 4);
      for (int k = 0; k < 4; ++k) {
        const ParameterUncertainty& p = rep.parameters[static_cast<std::size_t>(k)];
        if (!p.sd_si) continue;
        t[static_cast<std::size_t>(k)].add(est[k] - truth[k], *p.sd_si / p.sigma_si,
                                           !p.flags.empty());
      }
      if (const auto* ekf = dynamic_cast<const EkfRtsOptimizer*>(optimizer.get())) {
        auto& te = tally["ekf-rts (filter's own sd)"];
        te.resize(4);
        for (int k = 0; k < 4; ++k)
          te[static_cast<std::size_t>(k)].add(est[k] - truth[k], ekf->std_sigma()[k], false);
        line["ekf_std_sigma"] =
            std::vector<double>(ekf->std_sigma().data(), ekf->std_sigma().data() + 4);
      }
      if (jout) jout << line.dump() << "\n";
    }
    std::cerr << "\rinsid-uncertainty-study: seed " << seed << "/" << seeds << std::flush;
  }
  std::cerr << "\n";
  std::printf("%s flight of %g s after the alignment, grade %s, %d noise seeds, %d replicas\n\n",
              preset.c_str(), flight_s, grade.c_str(), seeds, replicas);
  std::printf(
      "| algorithm (sd) | parameter | runs | 95 %% coverage | |error|/sd RMS | runs flagged |\n"
      "|---|---|---|---|---|---|\n");
  for (const auto& [algo, ts] : tally)
    for (std::size_t k = 0; k < ts.size(); ++k) {
      const Tally& t = ts[k];
      if (t.runs == 0) continue;
      std::printf("| %s | %s | %d | %d/%d (%.0f %%) | %.2f | %d |\n", algo.c_str(),
                  names[k].c_str(), t.runs, t.covered, t.runs, 100.0 * t.covered / t.runs,
                  std::sqrt(t.z2 / t.runs), t.flagged);
    }
  for (const auto& [algo, w] : wall)
    std::printf("\nuncertainty wall time, %s: %.3f s per run\n", algo.c_str(), w / seeds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-uncertainty-study",
                           [&] { return uncertainty_study_main(argc, argv); });
}
