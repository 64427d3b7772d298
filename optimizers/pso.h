// Particle swarm optimisation, global-best topology with inertia weight (paper Table 4 preset:
// 10 particles, 40 iterations, w = 0.8, c1 = c2 = 2). Choices: see pso.cc and README.md.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct PsoParams {
  static constexpr std::string_view kAlgorithm = "PSO";

  int population = 10;          ///< particles
  double w = 0.8;               ///< inertia weight
  double c1 = 2.0;              ///< cognitive (personal-best) acceleration
  double c2 = 2.0;              ///< social (global-best) acceleration
  double v_max_fraction = 0.2;  ///< velocity clamp per dimension, as a fraction of box width

  static std::span<const ParameterField<PsoParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static PsoParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<PsoParams>(overrides);
  }
};

class PsoOptimizer final : public Optimizer {
 public:
  /// Throws std::invalid_argument on invalid params, bounds or config.
  PsoOptimizer(const Bounds& bounds, const RunConfig& config, const PsoParams& params = {});

  ParameterList parameters() const override { return params_.list(); }
  const PsoParams& params() const { return params_; }

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return iteration() == 0 ? "initial" : "velocity_update"; }

 private:
  PsoParams params_;
  Eigen::VectorXd v_max_;
  std::vector<Eigen::VectorXd> x_, v_, personal_best_x_;
  std::vector<double> personal_best_f_;
};

}  // namespace insid::opt
