// pagmo2 and Ceres behind baseline_backend.h (generic x86-64 build, hidden symbols).
#include "optimizers/baseline_backend.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>

#include <ceres/ceres.h>
#include <glog/logging.h>
#include <pagmo/algorithm.hpp>
#include <pagmo/algorithms/cmaes.hpp>
#include <pagmo/algorithms/compass_search.hpp>
#include <pagmo/algorithms/de.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>
#include <pagmo/types.hpp>

namespace insid::opt::backend {

GenerationalAlgorithm::~GenerationalAlgorithm() = default;

namespace {

struct Tape {
  bool record = true;
  std::vector<Vec> points;  // recorded (record) / expected (replay)
  Vec values;               // replay
  std::size_t next = 0;
};

// pagmo user-defined problem that records the requested points (returning a placeholder) or
// replays told values, checking each point bit for bit.
struct TapeProblem {
  std::shared_ptr<Tape> tape;
  Vec lower, upper;

  Vec fitness(const Vec& x) const {
    if (tape->record) {
      tape->points.push_back(x);
      return {0.0};
    }
    if (tape->next >= tape->points.size() || tape->points[tape->next] != x)
      throw std::logic_error(
          "pagmo bridge: the algorithm asked for a point it did not propose "
          "(its generation would depend on its own fitness values)");
    return {tape->values[tape->next++]};
  }
  std::pair<Vec, Vec> get_bounds() const { return {lower, upper}; }
  std::string get_name() const { return "insid tape"; }
};

class PagmoGenerational final : public GenerationalAlgorithm {
 public:
  PagmoGenerational(pagmo::algorithm algorithm, const Vec& lower, const Vec& upper, unsigned seed)
      : algorithm_(std::move(algorithm)), lower_(lower), upper_(upper), seed_(seed) {}

  void initialize(const std::vector<Vec>& x, const Vec& f) override {
    population_.emplace(pagmo::problem(TapeProblem{tape_, lower_, upper_}), 0u, seed_);
    for (std::size_t i = 0; i < x.size(); ++i) population_->push_back(x[i], {f[i]});
  }

  std::vector<Vec> propose() override {
    tape_->record = true;
    tape_->points.clear();
    pagmo::algorithm algorithm = algorithm_;  // deep copies; the real ones evolve in tell()
    pagmo::population population = *population_;
    algorithm.evolve(population);
    return tape_->points;
  }

  void tell(const Vec& f) override {
    if (f.size() != tape_->points.size())
      throw std::logic_error("pagmo bridge: " + std::to_string(f.size()) + " values for " +
                             std::to_string(tape_->points.size()) + " points");
    tape_->record = false;
    tape_->values = f;
    tape_->next = 0;
    population_ = algorithm_.evolve(std::move(*population_));
    if (tape_->next != f.size())
      throw std::logic_error("pagmo bridge: replayed " + std::to_string(tape_->next) + " of " +
                             std::to_string(f.size()) + " points");
  }

 private:
  pagmo::algorithm algorithm_;
  std::shared_ptr<Tape> tape_ = std::make_shared<Tape>();
  std::optional<pagmo::population> population_;
  Vec lower_, upper_;
  unsigned seed_;
};

struct Abandon {};

struct CallbackProblem {
  const std::function<bool(const Vec&, double&)>* fitness_fn = nullptr;
  Vec lower, upper;

  Vec fitness(const Vec& x) const {
    double f = 0.0;
    if (!(*fitness_fn)(x, f)) throw Abandon{};
    return {f};
  }
  std::pair<Vec, Vec> get_bounds() const { return {lower, upper}; }
  std::string get_name() const { return "insid callback"; }
};

}  // namespace

std::unique_ptr<GenerationalAlgorithm> make_cmaes(const CmaesSettings& s, const Vec& lower,
                                                  const Vec& upper, unsigned seed) {
  // gen = 1 per evolve() call, ftol = xtol = 0, memory = true (the state carries over).
  return std::make_unique<PagmoGenerational>(
      pagmo::algorithm(pagmo::cmaes(1u, s.cc, s.cs, s.c1, s.cmu, s.sigma0, 0.0, 0.0, true,
                                    s.force_bounds, seed)),
      lower, upper, seed);
}

std::unique_ptr<GenerationalAlgorithm> make_de(const DeSettings& s, const Vec& lower,
                                               const Vec& upper, unsigned seed) {
  return std::make_unique<PagmoGenerational>(
      pagmo::algorithm(pagmo::de(1u, s.F, s.CR, s.variant, 0.0, 0.0, seed)), lower, upper, seed);
}

bool compass_search(const Vec& x0, double f0, const Vec& lower, const Vec& upper,
                    double start_range, double stop_range, double reduction_coeff, unsigned seed,
                    const std::function<bool(const Vec& x, double& f)>& fitness) {
  pagmo::population population(pagmo::problem(CallbackProblem{&fitness, lower, upper}), 0u, seed);
  population.push_back(x0, {f0});
  const pagmo::compass_search algorithm(std::numeric_limits<unsigned>::max() - 1u, start_range,
                                        stop_range, reduction_coeff);
  try {
    algorithm.evolve(population);
  } catch (const Abandon&) {
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
namespace {

// Residuals (and Jacobian, once computed) of the last evaluated point: Ceres asks again for
// the point it has just accepted (with bounds, its projected line search already needed the
// candidate's gradient, hence its Jacobian).
struct ResidualCache {
  Vec x;
  Vec r;
  Vec J;  // row-major m x n; empty until computed at x
};

class CallbackCost final : public ceres::CostFunction {
 public:
  CallbackCost(const ResidualEvaluator& evaluate, ResidualCache& cache, const Vec& upper,
               double fd_step, bool& ended)
      : evaluate_(evaluate), cache_(cache), upper_(upper), fd_step_(fd_step), ended_(ended) {
    set_num_residuals(static_cast<int>(cache.r.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(upper.size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (ended_) return false;
    const std::size_t n = upper_.size();
    const Vec x(parameters[0], parameters[0] + n);
    const bool cached = cache_.x == x;
    const bool need_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (cached && (!need_jacobian || !cache_.J.empty())) {
      if (residuals != nullptr) std::copy(cache_.r.begin(), cache_.r.end(), residuals);
      if (need_jacobian) std::copy(cache_.J.begin(), cache_.J.end(), jacobians[0]);
      return true;
    }
    std::vector<Vec> points;
    Vec steps;
    if (!cached) points.push_back(x);
    if (need_jacobian) {
      for (std::size_t j = 0; j < n; ++j) {
        // Forward difference; backward where the forward point would leave the box.
        const double h = x[j] + fd_step_ <= upper_[j] ? fd_step_ : -fd_step_;
        Vec xj = x;
        xj[j] += h;
        points.push_back(std::move(xj));
        steps.push_back(h);
      }
    }
    std::vector<Vec> r;
    if (!points.empty()) {
      if (!evaluate_(points, r, need_jacobian ? "jacobian" : "step")) {
        ended_ = true;
        return false;
      }
      if (r.size() != points.size()) throw std::logic_error("LM: wrong number of residual vectors");
      for (const Vec& ri : r)
        if (ri.size() != cache_.r.size())
          throw std::runtime_error("LM: residual vector of length " + std::to_string(ri.size()) +
                                   ", expected " + std::to_string(cache_.r.size()));
    }
    std::size_t next = 0;
    if (!cached) {
      cache_.x = x;
      cache_.r = std::move(r[next++]);
      cache_.J.clear();
    }
    const Vec& base = cache_.r;
    const std::size_t m = base.size();
    if (residuals != nullptr) std::copy(base.begin(), base.end(), residuals);
    if (need_jacobian) {
      cache_.J.resize(m * n);
      double* J = cache_.J.data();  // row-major m x n
      for (std::size_t j = 0; j < n; ++j) {
        const Vec& rj = r[next++];
        const double inv_h = 1.0 / steps[j];
        for (std::size_t i = 0; i < m; ++i) J[i * n + j] = (rj[i] - base[i]) * inv_h;
      }
      std::copy(cache_.J.begin(), cache_.J.end(), jacobians[0]);
    }
    return true;
  }

 private:
  const ResidualEvaluator& evaluate_;
  ResidualCache& cache_;
  const Vec& upper_;
  double fd_step_;
  bool& ended_;
};

class EndCallback final : public ceres::IterationCallback {
 public:
  explicit EndCallback(const bool& ended) : ended_(ended) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return ended_ ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const bool& ended_;
};

}  // namespace

bool ceres_lm(const Vec& x0, const Vec& r0, const Vec& lower, const Vec& upper,
              const LmSettings& settings, const ResidualEvaluator& evaluate) {
  // Ceres reports an evaluation that fails at the start point (our end-of-run signal) at glog
  // level ERROR: keep glog quiet (insid does not use glog otherwise).
  static const bool quiet = [] {
    FLAGS_minloglevel = 3;
    return true;
  }();
  (void)quiet;
  const std::size_t n = x0.size();
  ResidualCache cache{x0, r0, {}};
  bool ended = false;
  Vec x = x0;
  ceres::Problem problem;
  problem.AddResidualBlock(new CallbackCost(evaluate, cache, upper, settings.fd_step, ended),
                           nullptr, x.data());
  for (std::size_t j = 0; j < n; ++j) {
    problem.SetParameterLowerBound(x.data(), static_cast<int>(j), lower[j]);
    problem.SetParameterUpperBound(x.data(), static_cast<int>(j), upper[j]);
  }
  EndCallback callback(ended);
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = settings.max_iterations;
  options.parameter_tolerance = settings.parameter_tolerance;
  options.function_tolerance = settings.function_tolerance;
  options.gradient_tolerance = settings.gradient_tolerance;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  options.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return !ended;
}

}  // namespace insid::opt::backend
