// Optimizers by name, for the command line and campaign runner:
//   auto optimizer = make_optimizer("pso", problem.bounds(), config, {{"w", 0.7}});
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

/// "ga", "pso", "pio", "dvpio".
std::vector<std::string> algorithm_names();

/// The algorithm's parameters with defaults overridden by `overrides`, validated. Throws
/// std::invalid_argument for an unknown algorithm or parameter (listing the valid ones) or an
/// invalid value (naming it).
std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config,
                                          const ParameterMap& overrides = {});

/// The algorithm's default parameters (the paper's Table 4 presets).
ParameterList default_parameters(std::string_view algorithm);

/// make_optimizer + run().
Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides = {});

}  // namespace insid::opt
