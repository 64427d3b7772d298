// Optimizers by name, for the command line and campaign runner:
//   auto optimizer = make_optimizer("pso", problem.bounds(), config, {{"w", 0.7}});
//   if (algorithm_traits("lm").least_squares) ...
// One table holds every algorithm: its name, its factory, its default parameters and its traits
// (what kind of algorithm it is, for the code that decides how to drive it or read its answer).
// Algorithms defined above optimizers/ (the EKF-RTS of identification/) add entries with
// register_algorithm; the table never names them.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

/// What an algorithm is. Code that treats algorithms differently asks these, never the name.
struct AlgorithmTraits {
  enum class Family {
    kPaper,            ///< the paper's four: ga, pso, pio, dvpio
    kBaseline,         ///< a generic reference baseline (optimizers/README.md)
    kProblemSpecific,  ///< registered from outside optimizers/, runs only on its own problem
    kExternal,         ///< "external:CMD", a program speaking the JSON-lines protocol
  };
  Family family = Family::kBaseline;
  /// Minimises the sum of squares of the problem's residual vector rather than the scalar
  /// fitness (Eq. 15): its estimate's covariance follows the Gauss-Newton least-squares step.
  bool least_squares = false;
  /// Needs the residual vectors of its candidates (a ResidualConsumer: the problem must be a
  /// ResidualProblem).
  bool needs_residuals = false;
  /// Needs the problem itself and scores its own candidates (a ProblemConsumer).
  bool needs_problem = false;
  /// Draws random numbers from RunConfig::seed (its population or its start points): runs with
  /// different seeds differ. False: the seed does not change the run.
  bool stochastic = true;
  /// One line saying what the algorithm is.
  std::string description;
};

/// Makes the optimizer from the name asked for (the external entry reads its command from
/// it), the box, the run configuration and the parameter overrides; throws
/// std::invalid_argument for an unknown parameter or an invalid value.
using OptimizerFactory = std::function<std::unique_ptr<Optimizer>(
    std::string_view name, const Bounds& bounds, const RunConfig& config,
    const ParameterMap& overrides)>;

/// One algorithm of the table.
struct AlgorithmEntry {
  /// The name it is asked for by; a name ending in ':' is a prefix ("external:" matches
  /// "external:CMD" for any CMD).
  std::string name;
  OptimizerFactory make;
  /// Its parameters with their defaults (the paper's Table 4 presets for the paper's four) and
  /// units.
  std::function<ParameterInfoList()> parameters;
  AlgorithmTraits traits;
};

/// Every algorithm: the paper's four, the reference baselines, then any registered ones
/// (e.g. "ekf-rts" from identification/). Prefix entries ("external:") are not listed.
std::vector<std::string> algorithm_names();
/// The paper's four: "ga", "pso", "pio", "dvpio".
std::vector<std::string> paper_algorithm_names();
/// The generic reference baselines (optimizers/README.md): "cmaes", "de", "compass", "lm",
/// "bobyqa", "neldermead".
std::vector<std::string> baseline_algorithm_names();

/// The table's entry for `algorithm` (a copy: the table may grow meanwhile). Throws
/// std::invalid_argument for an unknown name, listing the valid ones.
AlgorithmEntry algorithm_entry(std::string_view algorithm);
/// algorithm_entry(algorithm).traits.
AlgorithmTraits algorithm_traits(std::string_view algorithm);

/// The algorithm's parameters with defaults overridden by `overrides`, validated; besides the
/// names above, "external:CMD" runs CMD as an external optimizer (external.h). Throws
/// std::invalid_argument for an unknown algorithm or parameter (listing the valid ones) or an
/// invalid value (naming it).
std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config,
                                          const ParameterMap& overrides = {});

/// The algorithm's default parameters (the paper's Table 4 presets).
ParameterList default_parameters(std::string_view algorithm);
/// The same with each parameter's unit.
ParameterInfoList parameter_info(std::string_view algorithm);

/// make_optimizer + run() (which binds problem consumers and feeds residual consumers).
Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides = {});

/// Adds an algorithm defined outside optimizers/ (problem-specific, e.g. a Kalman filter that is
/// a ProblemConsumer) to the table; registering a registered name again replaces it.
/// Thread-safe. Throws std::invalid_argument for the name of a built-in algorithm, a prefix
/// name, or an entry without factory or parameters. Returns true, so that a static registrar can
/// be initialised from it.
bool register_algorithm(AlgorithmEntry entry);

}  // namespace insid::opt
