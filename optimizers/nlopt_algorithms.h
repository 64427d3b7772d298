// Reference baselines from NLopt (Johnson, Debian libnlopt-cxx-dev): BOBYQA (Powell 2009, bound
// constrained quadratic-model trust region) and Nelder-Mead (NLopt's bounded variant). Both are
// sequential: one evaluation per iteration, through a SolverBridge (solver_bridge.h). Starts and
// restarts: bridged.h. Choices: optimizers/README.md "Reference baselines".
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "optimizers/bridged.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct NloptParams {
  static constexpr std::string_view kAlgorithm = "NLopt";

  double initial_step = 0.25;  ///< BOBYQA rhobeg / Nelder-Mead simplex size (normalised units)
  double xtol_abs = 1e-10;     ///< a start ends (and the next begins) at this step size
  double ftol_rel = 0.0;       ///< relative fitness tolerance (0 = none)

  static std::span<const ParameterField<NloptParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static NloptParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<NloptParams>(overrides);
  }
};

class NloptOptimizer final : public detail::BridgedOptimizer {
 public:
  enum class Method { kBobyqa, kNelderMead };
  NloptOptimizer(Method method, const Bounds& bounds, const RunConfig& config,
                 const NloptParams& params = {});
  ~NloptOptimizer() override { stop_solver(); }
  ParameterList parameters() const override { return params_.list(); }

 protected:
  void solve(detail::SolverBridge& bridge) override;

 private:
  Method method_;
  NloptParams params_;
};

}  // namespace insid::opt
