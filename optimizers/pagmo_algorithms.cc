// pagmo2 baselines behind the ask/tell interface. Design (also in optimizers/README.md):
//
// CMA-ES and DE: generation by generation, without threads. pagmo's algorithms evolve a
// population by calling the problem's fitness one point at a time. Within one generation of
// pagmo::cmaes (sample lambda offspring, then evaluate them) and pagmo::de (trial vectors built
// from the previous generation's population and best: `popold`, `gbIter`), the points do not
// depend on the fitness values of the same generation. So ask() evolves a *copy* of the algorithm
// and population by one generation on a "tape" problem that records the requested points and
// returns a placeholder; those points are the batch. tell() evolves the real algorithm and
// population by the same generation on the tape in replay mode: it returns the told fitness in
// order and checks that every requested point is bit for bit the recorded one (std::logic_error
// otherwise). The evaluation count is pagmo's: the initial population (iteration 1) plus lambda
// (CMA-ES) or NP (DE) per generation. ftol and xtol are 0 (never stop on flatness), CMA-ES keeps
// its memory between evolve() calls (one call per generation), and pagmo's seeds derive from the
// run seed, so a run is deterministic for its seed.
//
// Compass search is sequential (each probe depends on the previous outcome) and runs through a
// SolverBridge (solver_bridge.h): one evaluation per iteration, exactly pagmo's sequence.
#include "optimizers/pagmo_algorithms.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "optimizers/baseline_backend.h"

namespace insid::opt {

unsigned pagmo_seed(std::uint64_t seed) {
  return static_cast<unsigned>(splitmix64(seed ^ 0x9a9a0c0ffee5ULL) >> 32);
}

namespace detail {
namespace {

backend::Vec to_vec(const Eigen::VectorXd& x) {
  return backend::Vec(x.data(), x.data() + x.size());
}
Eigen::VectorXd from_vec(const backend::Vec& x) {
  return Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
}

}  // namespace

struct PagmoState {
  std::unique_ptr<backend::GenerationalAlgorithm> algorithm;
};

}  // namespace detail

// ---------------------------------------------------------------------------------------------
std::span<const ParameterField<CmaesParams>> CmaesParams::fields() {
  static const ParameterField<CmaesParams> kFields[] = {
      {"population", &CmaesParams::population, "offspring per generation (lambda, >= 5)"},
      {"sigma0", &CmaesParams::sigma0, "initial step size, fraction of the box width"},
      {"cc", &CmaesParams::cc, "cumulation constant for C (-1 = automatic)"},
      {"cs", &CmaesParams::cs, "cumulation constant for sigma (-1 = automatic)"},
      {"c1", &CmaesParams::c1, "rank-one learning rate (-1 = automatic)"},
      {"cmu", &CmaesParams::cmu, "rank-mu learning rate (-1 = automatic)"},
      {"force_bounds", &CmaesParams::force_bounds, "1: clamp offspring to the box"},
  };
  return kFields;
}

std::string CmaesParams::validate() const {
  auto auto_or_unit = [](std::string_view name, double v) -> std::string {
    if (v == -1.0) return {};
    return check_range(kAlgorithm, name, v, 0.0, 1.0);
  };
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 5),
        check_positive(kAlgorithm, "sigma0", sigma0), auto_or_unit("cc", cc),
        auto_or_unit("cs", cs), auto_or_unit("c1", c1), auto_or_unit("cmu", cmu),
        check_range(kAlgorithm, "force_bounds", force_bounds, 0, 1)}) {
    if (!error.empty()) return error;
  }
  return {};
}

std::span<const ParameterField<DeParams>> DeParams::fields() {
  static const ParameterField<DeParams> kFields[] = {
      {"population", &DeParams::population, "population size NP (>= 5)"},
      {"F", &DeParams::F, "weight coefficient"},
      {"CR", &DeParams::CR, "crossover probability"},
      {"variant", &DeParams::variant, "pagmo DE variant 1..10 (2 = rand/1/exp)"},
  };
  return kFields;
}

std::string DeParams::validate() const {
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 5),
        check_range(kAlgorithm, "F", F, 0.0, 1.0), check_range(kAlgorithm, "CR", CR, 0.0, 1.0),
        check_range(kAlgorithm, "variant", variant, 1, 10)}) {
    if (!error.empty()) return error;
  }
  return {};
}

std::span<const ParameterField<CompassParams>> CompassParams::fields() {
  static const ParameterField<CompassParams> kFields[] = {
      {"start_range", &CompassParams::start_range, "initial step, fraction of the box width"},
      {"stop_range", &CompassParams::stop_range,
       "restart from a new point once the step is below this fraction"},
      {"reduction_coeff", &CompassParams::reduction_coeff,
       "step factor after a sweep without improvement"},
  };
  return kFields;
}

std::string CompassParams::validate() const {
  if (!(start_range > 0.0 && start_range <= 1.0))
    return check_range(kAlgorithm, "start_range", start_range, 0.0, 1.0);
  if (!(stop_range > 0.0 && stop_range < start_range))
    return "compass: stop_range must be in (0, start_range), got " + format_number(stop_range);
  if (!(reduction_coeff > 0.0 && reduction_coeff < 1.0))
    return "compass: reduction_coeff must be in (0, 1), got " + format_number(reduction_coeff);
  return {};
}

// ---------------------------------------------------------------------------------------------
PagmoPopulationOptimizer::PagmoPopulationOptimizer(std::string name, const Bounds& bounds,
                                                   const RunConfig& config, int population,
                                                   ParameterList parameters,
                                                   std::unique_ptr<detail::PagmoState> state)
    : Optimizer(std::move(name), bounds, config),
      population_(population),
      parameters_(std::move(parameters)),
      state_(std::move(state)) {
  check_initial_positions(population_);
}

PagmoPopulationOptimizer::~PagmoPopulationOptimizer() = default;

void PagmoPopulationOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  if (iteration() == 0) {
    batch = initial_population(population_);
    return;
  }
  for (const backend::Vec& x : state_->algorithm->propose()) batch.push_back(detail::from_vec(x));
  if (batch.empty()) throw std::logic_error(name() + ": pagmo proposed no point");
}

void PagmoPopulationOptimizer::accept(std::span<const Eigen::VectorXd> batch,
                                      std::span<const double> fitness) {
  if (iteration() == 0) {
    std::vector<backend::Vec> xs;
    for (const Eigen::VectorXd& x : batch) xs.push_back(detail::to_vec(x));
    state_->algorithm->initialize(xs, backend::Vec(fitness.begin(), fitness.end()));
    return;
  }
  state_->algorithm->tell(backend::Vec(fitness.begin(), fitness.end()));
}

namespace {

std::unique_ptr<detail::PagmoState> cmaes_state(const Bounds& bounds, const RunConfig& config,
                                                const CmaesParams& p) {
  if (std::string error = p.validate(); !error.empty()) throw std::invalid_argument(error);
  auto state = std::make_unique<detail::PagmoState>();
  backend::CmaesSettings s;
  s.cc = p.cc;
  s.cs = p.cs;
  s.c1 = p.c1;
  s.cmu = p.cmu;
  s.sigma0 = p.sigma0;
  s.force_bounds = p.force_bounds == 1;
  state->algorithm = backend::make_cmaes(s, detail::to_vec(bounds.lower),
                                         detail::to_vec(bounds.upper), pagmo_seed(config.seed));
  return state;
}

std::unique_ptr<detail::PagmoState> de_state(const Bounds& bounds, const RunConfig& config,
                                             const DeParams& p) {
  if (std::string error = p.validate(); !error.empty()) throw std::invalid_argument(error);
  auto state = std::make_unique<detail::PagmoState>();
  backend::DeSettings s;
  s.F = p.F;
  s.CR = p.CR;
  s.variant = static_cast<unsigned>(p.variant);
  state->algorithm = backend::make_de(s, detail::to_vec(bounds.lower), detail::to_vec(bounds.upper),
                                      pagmo_seed(config.seed));
  return state;
}

}  // namespace

CmaesOptimizer::CmaesOptimizer(const Bounds& bounds, const RunConfig& config,
                               const CmaesParams& params)
    : PagmoPopulationOptimizer("CMA-ES", bounds, config, params.population, params.list(),
                               cmaes_state(bounds, config, params)) {}

DeOptimizer::DeOptimizer(const Bounds& bounds, const RunConfig& config, const DeParams& params)
    : PagmoPopulationOptimizer("DE", bounds, config, params.population, params.list(),
                               de_state(bounds, config, params)) {}

// ---------------------------------------------------------------------------------------------
CompassOptimizer::CompassOptimizer(const Bounds& bounds, const RunConfig& config,
                                   const CompassParams& params)
    : detail::BridgedOptimizer("compass", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
}

void CompassOptimizer::solve(detail::SolverBridge& bridge) {
  const backend::Vec lower = detail::to_vec(bounds().lower);
  const backend::Vec upper = detail::to_vec(bounds().upper);
  const std::function<bool(const backend::Vec&, double&)> fitness = [&bridge](const backend::Vec& x,
                                                                              double& f) {
    std::vector<double> values;
    if (!bridge.request({detail::from_vec(x)}, values, nullptr, "probe")) return false;
    f = values[0];
    return true;
  };
  for (;;) {
    // One start: evaluate the start point, then pagmo's compass search until its step falls
    // below stop_range (max_fevals: effectively unlimited; the run's budget stops it).
    const Eigen::VectorXd x0 = start_point();
    std::vector<double> f0;
    if (!bridge.request({x0}, f0, nullptr, starts() == 1 ? "initial" : "restart")) return;
    if (!backend::compass_search(detail::to_vec(x0), f0[0], lower, upper, params_.start_range,
                                 params_.stop_range, params_.reduction_coeff,
                                 pagmo_seed(config().seed), fitness))
      return;
  }
}

}  // namespace insid::opt
