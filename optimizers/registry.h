// Optimizers by name, for the command line and campaign runner:
//   auto optimizer = make_optimizer("pso", problem.bounds(), config, {{"w", 0.7}});
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

/// Every algorithm: the paper's four, the reference baselines, then any registered ones
/// (e.g. "ekf-rts" from identification/).
std::vector<std::string> algorithm_names();
/// The paper's four: "ga", "pso", "pio", "dvpio".
std::vector<std::string> paper_algorithm_names();
/// The generic reference baselines (optimizers/README.md): "cmaes", "de", "compass", "lm",
/// "bobyqa", "neldermead".
std::vector<std::string> baseline_algorithm_names();

/// The algorithm's parameters with defaults overridden by `overrides`, validated; besides the
/// names above, "external:CMD" runs CMD as an external optimizer (external.h). Throws
/// std::invalid_argument for an unknown algorithm or parameter (listing the valid ones) or an
/// invalid value (naming it).
std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config,
                                          const ParameterMap& overrides = {});

/// The algorithm's default parameters (the paper's Table 4 presets).
ParameterList default_parameters(std::string_view algorithm);

/// make_optimizer + run() (which binds problem consumers and feeds residual consumers).
Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides = {});

/// An algorithm provided outside optimizers/ (problem-specific, e.g. a Kalman filter that is a
/// ProblemConsumer). Registering a name again replaces it; thread-safe.
struct AlgorithmFactory {
  std::function<std::unique_ptr<Optimizer>(const Bounds&, const RunConfig&, const ParameterMap&)>
      make;
  std::function<ParameterList()> defaults;
};
void register_algorithm(const std::string& name, AlgorithmFactory factory);

}  // namespace insid::opt
