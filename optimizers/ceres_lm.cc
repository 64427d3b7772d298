// Levenberg-Marquardt through Ceres on the residual vector r(x) (minimises 1/2 sum r_i^2; the
// result's fitness is still the problem's own, e.g. Eq. 15, of the points evaluated).
//
// Numeric differentiation: forward differences with a fixed step fd_step in the normalised box
// (backward where x + fd_step would leave the box), computed inside the cost function so that
// the base point and the n shifted points of one Jacobian form one batch (1 + n evaluations,
// scored together; Ceres's NumericDiffCostFunction would ask for them one by one). Ceres
// evaluates a trial point without a Jacobian and, when it accepts the step, asks for the
// Jacobian at the same point: the residuals of the last evaluated point are kept, so that
// Jacobian costs n evaluations, not n + 1. Nothing is evaluated that the count does not show.
//
// Bounds: Ceres's bound-constrained trust region (parameter bounds = the box). Ceres runs with
// LEVENBERG_MARQUARDT, DENSE_QR, one thread, silent. A start ends on Ceres's convergence tests
// (parameter_tolerance, function_tolerance, gradient 1e-16) or max_iterations_per_start; the
// next starts at a new uniform point (bridged.h). When the run's budget ends, the cost function
// returns false and an iteration callback aborts Ceres.
#include "optimizers/ceres_lm.h"

#include <stdexcept>

#include "optimizers/baseline_backend.h"

namespace insid::opt {

std::span<const ParameterField<LmParams>> LmParams::fields() {
  static const ParameterField<LmParams> kFields[] = {
      {"fd_step", &LmParams::fd_step, "forward-difference step, normalised units",
       ParameterUnit::kBoxDistance},
      {"max_iterations_per_start", &LmParams::max_iterations_per_start,
       "Ceres iterations of one start"},
      {"parameter_tolerance", &LmParams::parameter_tolerance, "Ceres parameter_tolerance"},
      {"function_tolerance", &LmParams::function_tolerance, "Ceres function_tolerance"},
  };
  return kFields;
}

std::string LmParams::validate() const {
  for (std::string error :
       {check_positive(kAlgorithm, "fd_step", fd_step),
        check_range(kAlgorithm, "fd_step", fd_step, 0.0, 0.1),
        check_at_least(kAlgorithm, "max_iterations_per_start", max_iterations_per_start, 1),
        check_at_least(kAlgorithm, "parameter_tolerance", parameter_tolerance, 0.0),
        check_at_least(kAlgorithm, "function_tolerance", function_tolerance, 0.0)}) {
    if (!error.empty()) return error;
  }
  return {};
}

LmOptimizer::LmOptimizer(const Bounds& bounds, const RunConfig& config, const LmParams& params)
    : detail::BridgedOptimizer("LM", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
}

void LmOptimizer::set_residuals(std::vector<std::vector<double>> residuals) {
  pending_residuals_ = std::move(residuals);
}

void LmOptimizer::accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) {
  if (pending_residuals_.size() != batch.size())
    throw std::logic_error(
        "LM needs the residual vectors of its candidates: drive it with "
        "opt::step / run / optimize on a problem that implements "
        "ResidualProblem");
  BridgedOptimizer::accept(batch, fitness);
}

void LmOptimizer::solve(detail::SolverBridge& bridge) {
  const int n = bounds().dimension();
  const backend::Vec lower(bounds().lower.data(), bounds().lower.data() + n);
  const backend::Vec upper(bounds().upper.data(), bounds().upper.data() + n);
  backend::LmSettings settings;
  settings.fd_step = params_.fd_step;
  settings.max_iterations = params_.max_iterations_per_start;
  settings.parameter_tolerance = params_.parameter_tolerance;
  settings.function_tolerance = params_.function_tolerance;
  const backend::ResidualEvaluator evaluate = [&bridge](const std::vector<backend::Vec>& points,
                                                        std::vector<backend::Vec>& residuals,
                                                        const std::string& label) {
    std::vector<Eigen::VectorXd> xs;
    for (const backend::Vec& p : points)
      xs.push_back(
          Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size())));
    std::vector<double> f;
    return bridge.request(std::move(xs), f, &residuals, label);
  };
  for (;;) {
    // The start point first, alone: its residual vector fixes the problem's size for Ceres and
    // serves the first Jacobian.
    const Eigen::VectorXd x0 = start_point();
    std::vector<double> f;
    std::vector<backend::Vec> r;
    if (!bridge.request({x0}, f, &r, starts() == 1 ? "initial" : "restart")) return;
    if (r.size() != 1 || r[0].empty()) throw std::runtime_error("LM: empty residual vector");
    if (!backend::ceres_lm(backend::Vec(x0.data(), x0.data() + n), r[0], lower, upper, settings,
                           evaluate))
      return;
  }
}

}  // namespace insid::opt
