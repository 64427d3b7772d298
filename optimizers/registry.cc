#include "optimizers/registry.h"

#include <stdexcept>

#include "optimizers/dvpio.h"
#include "optimizers/ga.h"
#include "optimizers/pio.h"
#include "optimizers/pso.h"

namespace insid::opt {

std::vector<std::string> algorithm_names() { return {"ga", "pso", "pio", "dvpio"}; }

namespace {

[[noreturn]] void unknown_algorithm(std::string_view algorithm) {
  std::string names;
  for (const std::string& name : algorithm_names()) names += (names.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown optimizer '" + std::string(algorithm) +
                              "'; valid optimizers: " + names);
}

}  // namespace

std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config,
                                          const ParameterMap& overrides) {
  if (algorithm == "ga") {
    return std::make_unique<GaOptimizer>(bounds, config, GaParams::from_map(overrides));
  }
  if (algorithm == "pso") {
    return std::make_unique<PsoOptimizer>(bounds, config, PsoParams::from_map(overrides));
  }
  if (algorithm == "pio") {
    return std::make_unique<PioOptimizer>(bounds, config, PioParams::from_map(overrides));
  }
  if (algorithm == "dvpio") {
    return std::make_unique<DvpioOptimizer>(bounds, config, DvpioParams::from_map(overrides));
  }
  unknown_algorithm(algorithm);
}

ParameterList default_parameters(std::string_view algorithm) {
  if (algorithm == "ga") return GaParams{}.list();
  if (algorithm == "pso") return PsoParams{}.list();
  if (algorithm == "pio") return PioParams{}.list();
  if (algorithm == "dvpio") return DvpioParams{}.list();
  unknown_algorithm(algorithm);
}

Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides) {
  const std::unique_ptr<Optimizer> optimizer =
      make_optimizer(algorithm, problem.bounds(), config, overrides);
  return run(*optimizer, problem);
}

}  // namespace insid::opt
