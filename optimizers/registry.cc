#include "optimizers/registry.h"

#include <map>
#include <mutex>
#include <stdexcept>

#include "optimizers/ceres_lm.h"
#include "optimizers/dvpio.h"
#include "optimizers/external.h"
#include "optimizers/ga.h"
#include "optimizers/nlopt_algorithms.h"
#include "optimizers/pagmo_algorithms.h"
#include "optimizers/pio.h"
#include "optimizers/pso.h"

namespace insid::opt {
namespace {

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}
std::map<std::string, AlgorithmFactory>& registered() {
  static std::map<std::string, AlgorithmFactory> factories;
  return factories;
}
const AlgorithmFactory* find_registered(std::string_view algorithm) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  const auto it = registered().find(std::string(algorithm));
  return it == registered().end() ? nullptr : &it->second;
}

[[noreturn]] void unknown_algorithm(std::string_view algorithm) {
  std::string names;
  for (const std::string& name : algorithm_names()) names += (names.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown optimizer '" + std::string(algorithm) +
                              "'; valid optimizers: " + names);
}

}  // namespace

std::vector<std::string> paper_algorithm_names() { return {"ga", "pso", "pio", "dvpio"}; }

std::vector<std::string> baseline_algorithm_names() {
  return {"cmaes", "de", "compass", "lm", "bobyqa", "neldermead"};
}

std::vector<std::string> algorithm_names() {
  std::vector<std::string> names = paper_algorithm_names();
  for (const std::string& name : baseline_algorithm_names()) names.push_back(name);
  std::lock_guard<std::mutex> lock(registry_mutex());
  for (const auto& [name, factory] : registered()) names.push_back(name);
  return names;
}

void register_algorithm(const std::string& name, AlgorithmFactory factory) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  registered()[name] = std::move(factory);
}

std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config, const ParameterMap& overrides) {
  if (is_external_algorithm(algorithm)) {
    return std::make_unique<ExternalOptimizer>(
        std::string(algorithm.substr(kExternalPrefix.size())), bounds, config,
        ExternalParams::from_map(overrides));
  }
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
  if (algorithm == "cmaes") {
    return std::make_unique<CmaesOptimizer>(bounds, config, CmaesParams::from_map(overrides));
  }
  if (algorithm == "de") {
    return std::make_unique<DeOptimizer>(bounds, config, DeParams::from_map(overrides));
  }
  if (algorithm == "compass") {
    return std::make_unique<CompassOptimizer>(bounds, config, CompassParams::from_map(overrides));
  }
  if (algorithm == "lm") {
    return std::make_unique<LmOptimizer>(bounds, config, LmParams::from_map(overrides));
  }
  if (algorithm == "bobyqa") {
    return std::make_unique<NloptOptimizer>(NloptOptimizer::Method::kBobyqa, bounds, config,
                                            NloptParams::from_map(overrides));
  }
  if (algorithm == "neldermead") {
    return std::make_unique<NloptOptimizer>(NloptOptimizer::Method::kNelderMead, bounds, config,
                                            NloptParams::from_map(overrides));
  }
  if (const AlgorithmFactory* factory = find_registered(algorithm)) {
    return factory->make(bounds, config, overrides);
  }
  unknown_algorithm(algorithm);
}

ParameterList default_parameters(std::string_view algorithm) {
  if (is_external_algorithm(algorithm)) return ExternalParams{}.list();
  if (algorithm == "ga") return GaParams{}.list();
  if (algorithm == "pso") return PsoParams{}.list();
  if (algorithm == "pio") return PioParams{}.list();
  if (algorithm == "dvpio") return DvpioParams{}.list();
  if (algorithm == "cmaes") return CmaesParams{}.list();
  if (algorithm == "de") return DeParams{}.list();
  if (algorithm == "compass") return CompassParams{}.list();
  if (algorithm == "lm") return LmParams{}.list();
  if (algorithm == "bobyqa" || algorithm == "neldermead") return NloptParams{}.list();
  if (const AlgorithmFactory* factory = find_registered(algorithm)) return factory->defaults();
  unknown_algorithm(algorithm);
}

Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides) {
  const std::unique_ptr<Optimizer> optimizer =
      make_optimizer(algorithm, problem.bounds(), config, overrides);
  return run(*optimizer, problem);
}

}  // namespace insid::opt
