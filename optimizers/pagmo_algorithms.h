// Reference baselines from pagmo2 (Biscani & Izzo 2020, Debian libpagmo-dev): CMA-ES (Hansen's
// (mu/mu_w, lambda) CMA-ES, pagmo::cmaes), differential evolution (Storn & Price 1997,
// pagmo::de) and compass search (pagmo::compass_search; an ablation of DVPIO's axis-aligned
// probing without the swarm). Design and choices: optimizers/README.md "Reference baselines".
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/bridged.h"
#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct CmaesParams {
  static constexpr std::string_view kAlgorithm = "CMA-ES";

  int population = 10;   ///< lambda (offspring per generation, >= 5); mu = lambda / 2
  double sigma0 = 0.3;   ///< initial step size as a fraction of the box width
  double cc = -1.0;      ///< cumulation constant for C (-1 = pagmo's automatic value)
  double cs = -1.0;      ///< cumulation constant for sigma (-1 = automatic)
  double c1 = -1.0;      ///< rank-one learning rate (-1 = automatic)
  double cmu = -1.0;     ///< rank-mu learning rate (-1 = automatic)
  int force_bounds = 1;  ///< 1: clamp offspring to the box (pagmo force_bounds)

  static std::span<const ParameterField<CmaesParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static CmaesParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<CmaesParams>(overrides);
  }
};

struct DeParams {
  static constexpr std::string_view kAlgorithm = "DE";

  int population = 10;  ///< NP (>= 5)
  double F = 0.8;       ///< weight coefficient
  double CR = 0.9;      ///< crossover probability
  int variant = 2;      ///< pagmo's variant 1..10 (2 = rand/1/exp)

  static std::span<const ParameterField<DeParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static DeParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<DeParams>(overrides);
  }
};

struct CompassParams {
  static constexpr std::string_view kAlgorithm = "compass";

  double start_range = 0.1;      ///< initial step, fraction of the box width
  double stop_range = 1e-9;      ///< restart once the step is below this fraction
  double reduction_coeff = 0.5;  ///< step factor after a sweep without improvement

  static std::span<const ParameterField<CompassParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static CompassParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<CompassParams>(overrides);
  }
};

namespace detail {
struct PagmoState;  // pagmo objects (kept out of this header)
}

/// A pagmo population-based algorithm driven one generation per iteration (CMA-ES, DE).
/// Iteration 1 is the initial population (uniform in the box, initial_positions first); each
/// further iteration is one pagmo generation of `population` offspring.
class PagmoPopulationOptimizer : public Optimizer {
 public:
  ~PagmoPopulationOptimizer() override;
  ParameterList parameters() const override { return parameters_; }

 protected:
  PagmoPopulationOptimizer(std::string name, const Bounds& bounds, const RunConfig& config,
                           int population, ParameterList parameters,
                           std::unique_ptr<detail::PagmoState> state);
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return iteration() == 0 ? "initial" : "generation"; }

 private:
  int population_;
  ParameterList parameters_;
  std::unique_ptr<detail::PagmoState> state_;
};

class CmaesOptimizer final : public PagmoPopulationOptimizer {
 public:
  CmaesOptimizer(const Bounds& bounds, const RunConfig& config, const CmaesParams& params = {});
};

class DeOptimizer final : public PagmoPopulationOptimizer {
 public:
  DeOptimizer(const Bounds& bounds, const RunConfig& config, const DeParams& params = {});
};

/// pagmo::compass_search, one evaluation per iteration (it is sequential: each probe depends on
/// the previous one), restarted from a new uniform point when the step falls below stop_range.
class CompassOptimizer final : public detail::BridgedOptimizer {
 public:
  CompassOptimizer(const Bounds& bounds, const RunConfig& config, const CompassParams& params = {});
  ~CompassOptimizer() override { stop_solver(); }
  ParameterList parameters() const override { return params_.list(); }

 protected:
  void solve(detail::SolverBridge& bridge) override;

 private:
  CompassParams params_;
};

/// pagmo's 32-bit seed for a run seed.
unsigned pagmo_seed(std::uint64_t seed);

}  // namespace insid::opt
