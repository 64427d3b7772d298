#include "optimizers/parameters.h"

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "optimizers/dvpio.h"
#include "optimizers/ga.h"
#include "optimizers/pio.h"
#include "optimizers/pso.h"
#include "optimizers/registry.h"

namespace insid::opt {
namespace {

// The message of the std::invalid_argument thrown by make_optimizer(algorithm, ...).
std::string rejection(const std::string& algorithm, const ParameterMap& overrides,
                      RunConfig config = {}) {
  try {
    make_optimizer(algorithm, Bounds::unit_box(4), config, overrides);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Parameters, DefaultsAreThePaperTable4Presets) {
  EXPECT_EQ(GaParams{}.list(), (ParameterList{{"population", 20},
                                              {"crossover_prob", 0.5},
                                              {"mutation_prob", 0.2},
                                              {"tournament_size", 2},
                                              {"sbx_eta", 15},
                                              {"mutation_eta", 20},
                                              {"elite_count", 1}}));
  EXPECT_EQ(PsoParams{}.list(),
            (ParameterList{
                {"population", 10}, {"w", 0.8}, {"c1", 2}, {"c2", 2}, {"v_max_fraction", 0.2}}));
  const ParameterList pio = PioParams{}.list();
  EXPECT_EQ(pio[0], (std::pair<std::string, double>("population", 10)));
  EXPECT_EQ(pio[1], (std::pair<std::string, double>("R", 0.05)));
  EXPECT_EQ(pio[2], (std::pair<std::string, double>("C", 1.0)));
  const DvpioParams dvpio;
  EXPECT_EQ(dvpio.population, 10);
  EXPECT_EQ(dvpio.R, 0.05);
  EXPECT_EQ(dvpio.C, 1.0);
  EXPECT_EQ(dvpio.d_initial, 0.05 / 4.0);  // 0.05 sigma in a [-4, 4] sigma box mapped to [-1, 1]
  RunConfig config;
  EXPECT_EQ(config.max_iterations, 40);
  for (const std::string& name : algorithm_names()) {
    EXPECT_EQ(make_optimizer(name, Bounds::unit_box(4), config)->parameters(),
              default_parameters(name));
  }
}

TEST(Parameters, SetByNameAndFromMap) {
  PsoParams pso;
  pso.set("w", 0.5);
  pso.set("population", 12);
  EXPECT_EQ(pso.w, 0.5);
  EXPECT_EQ(pso.population, 12);
  const DvpioParams dvpio = DvpioParams::from_map({{"dist_threshold", 0.01}, {"d_max", 0.25}});
  EXPECT_EQ(dvpio.dist_threshold, 0.01);
  EXPECT_EQ(dvpio.d_max, 0.25);
  const auto optimizer = make_optimizer("ga", Bounds::unit_box(2), {}, {{"mutation_prob", 0.1}});
  EXPECT_EQ(optimizer->parameters()[2], (std::pair<std::string, double>("mutation_prob", 0.1)));
}

TEST(Parameters, InvalidValuesAreRejectedWithTheValueNamed) {
  EXPECT_EQ(rejection("pso", {{"w", 1.7}}), "PSO: w must be in [0, 1], got 1.7");
  EXPECT_EQ(rejection("pso", {{"population", 0}}),
            "PSO: population must be finite and >= 1, got 0");
  EXPECT_EQ(rejection("pso", {{"v_max_fraction", 0}}),
            "PSO: v_max_fraction must be positive and finite, got 0");
  EXPECT_EQ(rejection("ga", {{"crossover_prob", 1.5}}),
            "GA: crossover_prob must be in [0, 1], got 1.5");
  EXPECT_EQ(rejection("ga", {{"tournament_size", 30}}),
            "GA: tournament_size must be in [1, 20], got 30");
  EXPECT_EQ(rejection("pio", {{"R", -0.1}}), "PIO: R must be in [0, 1], got -0.1");
  EXPECT_EQ(rejection("pio", {{"landmark_fraction", 2}}),
            "PIO: landmark_fraction must be in [0, 1], got 2");
  EXPECT_EQ(rejection("dvpio", {{"d_initial", 0.75}}),
            "DVPIO: d_initial must be in [1e-06, 0.5], got 0.75");
  EXPECT_EQ(rejection("dvpio", {{"d_min", 0.6}}),
            "DVPIO: d_min must be <= d_max, got d_min 0.6 > d_max 0.5");
  EXPECT_EQ(rejection("dvpio", {{"dist_threshold", std::nan("")}}),
            "DVPIO: dist_threshold must be finite and >= 0, got nan");
  EXPECT_EQ(rejection("pso", {{"population", 10.5}}),
            "PSO: population must be an integer, got 10.5");
}

TEST(Parameters, UnknownNamesListTheValidOnes) {
  EXPECT_EQ(rejection("pso", {{"inertia", 0.5}}),
            "PSO: unknown parameter 'inertia'; valid parameters: population, w, c1, c2, "
            "v_max_fraction");
  EXPECT_EQ(rejection("annealing", {}),
            "unknown optimizer 'annealing'; valid optimizers: ga, pso, pio, dvpio, cmaes, de, "
            "compass, lm, bobyqa, neldermead");
  EXPECT_THROW(default_parameters("annealing"), std::invalid_argument);
}

TEST(Parameters, RunConfigIsValidated) {
  RunConfig config;
  config.max_iterations = 0;
  EXPECT_EQ(rejection("pso", {}, config),
            "run: set max_iterations or max_evaluations (both are 0 = no limit)");
  config.max_evaluations = -5;
  EXPECT_EQ(rejection("pso", {}, config), "run: max_evaluations must be >= 0, got -5");
  config = RunConfig{};
  config.initial_positions = {Eigen::Vector4d(0.0, 0.0, 2.0, 0.0)};
  EXPECT_EQ(rejection("pio", {}, config),
            "PIO: initial position 0 [0, 0, 2, 0] is not inside the box");
  config.initial_positions.assign(11, Eigen::Vector4d::Zero());
  EXPECT_EQ(rejection("dvpio", {}, config), "DVPIO: 11 initial positions for a population of 10");
}

}  // namespace
}  // namespace insid::opt
