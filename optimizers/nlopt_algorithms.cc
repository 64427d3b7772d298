// NLopt baselines: BOBYQA (NLOPT_LN_BOBYQA) and Nelder-Mead (NLOPT_LN_NELDERMEAD), each objective
// call one batch of one point through the SolverBridge. No evaluation limit is given to NLopt:
// the run's budget ends it (the bridge then stops NLopt with nlopt::forced_stop). A start ends
// when NLopt stops on xtol_abs / ftol_rel (or reports round-off); the next starts at a new
// uniform point (bridged.h).
#include "optimizers/nlopt_algorithms.h"

#include <stdexcept>
#include <vector>

#include <nlopt.hpp>

namespace insid::opt {

std::span<const ParameterField<NloptParams>> NloptParams::fields() {
  static const ParameterField<NloptParams> kFields[] = {
      {"initial_step", &NloptParams::initial_step,
       "initial trust radius (BOBYQA) / simplex size (Nelder-Mead), normalised units",
       ParameterUnit::kBoxDistance},
      {"xtol_abs", &NloptParams::xtol_abs, "step size that ends a start (normalised units)",
       ParameterUnit::kBoxDistance},
      {"ftol_rel", &NloptParams::ftol_rel, "relative fitness change that ends a start (0 = none)"},
  };
  return kFields;
}

std::string NloptParams::validate() const {
  for (std::string error : {check_positive(kAlgorithm, "initial_step", initial_step),
                            check_range(kAlgorithm, "initial_step", initial_step, 0.0, 1.0),
                            check_positive(kAlgorithm, "xtol_abs", xtol_abs),
                            check_at_least(kAlgorithm, "ftol_rel", ftol_rel, 0.0)}) {
    if (!error.empty()) return error;
  }
  return {};
}

NloptOptimizer::NloptOptimizer(Method method, const Bounds& bounds, const RunConfig& config,
                               const NloptParams& params)
    : detail::BridgedOptimizer(method == Method::kBobyqa ? "BOBYQA" : "Nelder-Mead", bounds,
                               config),
      method_(method),
      params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
}

namespace {

struct ObjectiveContext {
  detail::SolverBridge* bridge;
  std::int64_t requests = 0;
};

double objective(const std::vector<double>& x, std::vector<double>& /*grad*/, void* data) {
  auto* ctx = static_cast<ObjectiveContext*>(data);
  std::vector<double> f;
  Eigen::VectorXd point =
      Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
  if (!ctx->bridge->request({std::move(point)}, f, nullptr, "objective"))
    throw nlopt::forced_stop();
  ++ctx->requests;
  return f[0];
}

}  // namespace

void NloptOptimizer::solve(detail::SolverBridge& bridge) {
  const int n = bounds().dimension();
  const std::vector<double> lower(bounds().lower.data(), bounds().lower.data() + n);
  const std::vector<double> upper(bounds().upper.data(), bounds().upper.data() + n);
  for (;;) {
    const Eigen::VectorXd x0 = start_point();
    nlopt::opt opt(method_ == Method::kBobyqa ? nlopt::LN_BOBYQA : nlopt::LN_NELDERMEAD,
                   static_cast<unsigned>(n));
    opt.set_lower_bounds(lower);
    opt.set_upper_bounds(upper);
    ObjectiveContext ctx{&bridge};
    opt.set_min_objective(objective, &ctx);
    opt.set_xtol_abs(params_.xtol_abs);
    opt.set_xtol_rel(0.0);
    opt.set_ftol_rel(params_.ftol_rel);
    opt.set_ftol_abs(0.0);
    opt.set_maxeval(0);
    opt.set_initial_step(params_.initial_step);
    std::vector<double> x(x0.data(), x0.data() + n);
    double f = 0.0;
    try {
      opt.optimize(x, f);
    } catch (const nlopt::forced_stop&) {
      return;  // the run has ended
    } catch (const nlopt::roundoff_limited&) {
      // converged as far as round-off allows: next start
    } catch (const std::runtime_error&) {
      if (bridge.aborting()) return;
      if (ctx.requests == 0) throw;  // failed before evaluating anything: would loop forever
    }
    if (bridge.aborting()) return;
  }
}

}  // namespace insid::opt
