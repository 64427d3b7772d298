// Reference baseline: Levenberg-Marquardt (Ceres Solver, Agarwal, Mierle et al., Debian
// libceres-dev) on the problem's residual vector, with a numerically differentiated Jacobian.
// Needs a problem that also implements ResidualProblem (problem.h) and a driver that hands the
// residuals over (opt::step / run / run_together / registry optimize; optimizer.h). Every
// residual evaluation is one evaluation of the problem: the base point and each Jacobian column
// count. Design: ceres_lm.cc and optimizers/README.md "Reference baselines".
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "optimizers/bridged.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct LmParams {
  static constexpr std::string_view kAlgorithm = "LM";

  double fd_step = 2.5e-4;             ///< forward-difference step (normalised units)
  int max_iterations_per_start = 50;   ///< Ceres max_num_iterations of one start
  double parameter_tolerance = 1e-10;  ///< Ceres parameter_tolerance (relative step)
  double function_tolerance = 1e-12;   ///< Ceres function_tolerance (relative cost change)

  static std::span<const ParameterField<LmParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static LmParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<LmParams>(overrides);
  }
};

class LmOptimizer final : public detail::BridgedOptimizer, public ResidualConsumer {
 public:
  LmOptimizer(const Bounds& bounds, const RunConfig& config, const LmParams& params = {});
  ~LmOptimizer() override { stop_solver(); }
  ParameterList parameters() const override { return params_.list(); }
  void set_residuals(std::vector<std::vector<double>> residuals) override;

 protected:
  void solve(detail::SolverBridge& bridge) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;

 private:
  LmParams params_;
};

}  // namespace insid::opt
