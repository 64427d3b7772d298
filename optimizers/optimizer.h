// Ask/tell core shared by every optimizer, the run configuration, the result, and drivers.
//
//   auto optimizer = make_optimizer("dvpio", problem.bounds(), config);   // registry.h
//   while (!optimizer->done()) {
//     std::span<const Eigen::VectorXd> batch = optimizer->ask();
//     std::vector<double> f(batch.size());
//     problem.evaluate_batch(batch, f);
//     optimizer->tell(f);
//   }
//   const Result& result = optimizer->result();
//
// run() is that loop; run_together() advances several optimizers generation by generation and
// scores all their candidates in one evaluate_batch() call (a campaign's shared batch; the one
// lock-step driver of insid, used by campaigns through its hooks).
//
// Iterations. One iteration = one batch asked and told. Iteration 1 evaluates the initial
// population, so the paper's "10 particles, 40 iterations" is 40 batches of 10 = 400
// evaluations. Budgets: the run stops after max_iterations iterations or max_evaluations
// evaluations, whichever comes first, or once the best fitness is <= target_fitness (several at
// once are reported as target, then iterations, then evaluations). The
// evaluation budget is never exceeded: when the next batch does not fit, ask() returns only its
// first (remaining-budget) candidates; they count towards the best-so-far and the trace, and
// the run then ends with Termination::kEvaluations (the algorithm does not update on a
// truncated batch). All draws come from the run's seed (random.h) inside ask()/tell().
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "base/enum_table.h"
#include "optimizers/parameters.h"
#include "optimizers/problem.h"
#include "optimizers/random.h"

namespace insid::opt {

struct RunConfig {
  std::uint64_t seed = 1;
  int max_iterations = 40;           ///< batches, the initial one included; 0 = no limit
  std::int64_t max_evaluations = 0;  ///< 0 = no limit; at least one of the two limits is set
  double target_fitness = -std::numeric_limits<double>::infinity();  ///< stop when best <= it
  bool record_positions = false;  ///< keep every batch's positions and fitness in history
  /// Optional starting points (in the box) used for the first members of the initial
  /// population, the rest drawn uniformly; at most the population size.
  std::vector<Eigen::VectorXd> initial_positions;

  /// Empty when valid, else a message naming the field and value.
  std::string validate() const;
};

enum class Termination {
  kNone,         ///< still running
  kIterations,   ///< max_iterations reached
  kEvaluations,  ///< max_evaluations reached
  kTarget,       ///< best fitness <= target_fitness
};
/// The names written to results ("termination").
inline constexpr EnumTable<Termination, 4> kTerminationNames{
    "termination",
    {{{Termination::kNone, "running"},
      {Termination::kIterations, "iterations"},
      {Termination::kEvaluations, "evaluations"},
      {Termination::kTarget, "target"}}}};
inline std::string_view to_string(Termination termination) {
  return kTerminationNames.name(termination);
}

/// One iteration (batch). Population statistics are over the candidates evaluated in it.
struct IterationRecord {
  int iteration = 0;             ///< 1-based; iteration 1 evaluates the initial population
  std::int64_t evaluations = 0;  ///< evaluations so far, this batch included
  int batch_size = 0;            ///< candidates evaluated in this iteration
  double best_fitness = 0.0;     ///< best-so-far after this iteration
  double median_fitness = 0.0;   ///< median fitness of this iteration's candidates
  double diversity = 0.0;        ///< mean ||x_i - x_best|| of this iteration's candidates
  std::string phase;             ///< operator that produced the batch ("initial", ...)
  // DVPIO only (false / empty for the other algorithms):
  bool premature = false;            ///< batch made in premature mode (Eq. 12 probes)
  Eigen::VectorXd d_positive;        ///< d_jp used by this batch's probes (Eq. 11)
  Eigen::VectorXd d_negative;        ///< d_jn used by this batch's probes (Eq. 11)
  std::vector<int> direction_flags;  ///< T_j of this batch (Eq. 13): -1, +1, 0 = not probed
  // Only with RunConfig::record_positions:
  std::vector<Eigen::VectorXd> positions;  ///< the batch
  std::vector<double> fitness;             ///< its fitness
};

struct Result {
  std::string algorithm;
  ParameterList parameters;
  std::uint64_t seed = 0;
  Eigen::VectorXd best_x;
  double best_f = std::numeric_limits<double>::infinity();
  std::int64_t evaluations = 0;
  int iterations = 0;
  double wall_time_s = 0.0;  ///< from the first ask() to the end (or to now, while running)
  Termination termination = Termination::kNone;
  std::vector<IterationRecord> history;     ///< one per iteration
  std::vector<double> best_per_evaluation;  ///< best-so-far after each evaluation
};

class Optimizer {
 public:
  virtual ~Optimizer() = default;
  Optimizer(const Optimizer&) = delete;
  Optimizer& operator=(const Optimizer&) = delete;

  const std::string& name() const { return result_.algorithm; }
  const Bounds& bounds() const { return bounds_; }
  const RunConfig& config() const { return config_; }
  /// The algorithm's parameters by name (for the result and JSON).
  virtual ParameterList parameters() const = 0;

  bool done() const { return result_.termination != Termination::kNone; }
  /// The candidates to evaluate next (non-empty). Repeated calls before tell() return the
  /// same batch. The span stays valid until tell(). Throws std::logic_error when done().
  std::span<const Eigen::VectorXd> ask();
  /// Their fitness, in the same order. Throws std::invalid_argument on a size mismatch and
  /// NonFiniteFitnessError (naming the candidate) on NaN/inf; the batch then stays pending.
  void tell(std::span<const double> fitness);
  /// Live result; final once done().
  const Result& result() const { return result_; }

 protected:
  /// Validates bounds and config (throws std::invalid_argument).
  Optimizer(std::string name, Bounds bounds, RunConfig config);

  /// Appends the candidates of iteration `iteration() + 1` to `batch` (empty on entry).
  virtual void propose(std::vector<Eigen::VectorXd>& batch) = 0;
  /// Consumes the fitness of the batch just proposed (never a truncated one). The best-so-far
  /// (best_x(), best_f()) already includes this batch.
  virtual void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) = 0;
  /// Adds algorithm-specific fields to the record of the iteration just told (also called for
  /// a truncated final batch, for which accept() was not called).
  virtual void annotate(IterationRecord& record) const { (void)record; }
  /// Name of the operator that produced the batch just proposed, for the history.
  virtual std::string phase() const = 0;

  /// Completed iterations (0 before the initial population has been told).
  int iteration() const { return result_.iterations; }
  Rng& rng() { return rng_; }
  const Eigen::VectorXd& best_x() const { return result_.best_x; }
  double best_f() const { return result_.best_f; }
  /// Iterations the run will make if the evaluation budget does not stop it first (with only an
  /// evaluation budget: ceil(max_evaluations / population)). Used for operator schedules.
  int planned_iterations(int population) const;

  /// Throws std::invalid_argument if config().initial_positions has more than `population`
  /// points, or points of the wrong size or outside the box. Call from derived constructors.
  void check_initial_positions(int population) const;
  /// `population` points: config().initial_positions first, the rest uniform in the box.
  std::vector<Eigen::VectorXd> initial_population(int population);
  /// x clamped to the box.
  Eigen::VectorXd clamp(const Eigen::VectorXd& x) const;
  /// Starts the run's wall clock now (it otherwise starts at the first ask()): for work done
  /// before the first batch, e.g. a Kalman filter pass in ProblemConsumer::bind.
  void start_clock();
  /// How the run ends once `iterations` batches are counted (the batch being told included), or
  /// kNone: target, then iterations, then evaluations, the rule tell() applies after accept().
  Termination termination_after(int iterations) const;

 private:
  void record_iteration(std::span<const double> fitness);
  void finish(Termination termination);

  Bounds bounds_;
  RunConfig config_;
  Rng rng_;
  Result result_;
  std::vector<Eigen::VectorXd> batch_;
  bool pending_ = false;
  bool truncated_ = false;
  std::string pending_phase_;
  std::optional<std::chrono::steady_clock::time_point> start_;
};

/// Optional interfaces of an optimizer (reference baselines, optimizers/README.md):
///  - ResidualConsumer: needs each candidate's residual vector (Levenberg-Marquardt). A driver
///    evaluates the batch with ResidualProblem::evaluate_residual_batch, hands the residuals over
///    with set_residuals() and then calls tell() with the fitness from the same runs.
///  - ProblemConsumer: needs to see the problem once before the first ask() (e.g. a Kalman
///    filter that reads the data itself); bind() is called by the drivers below.
/// step(), run(), run_together() and registry.h's optimize() do all of this; a hand-written
/// ask / evaluate_batch / tell loop works for every optimizer that implements neither.
class ResidualConsumer {
 public:
  virtual ~ResidualConsumer() = default;
  /// Residual vectors of the pending batch, in its order (call before tell()).
  virtual void set_residuals(std::vector<std::vector<double>> residuals) = 0;
};

class ProblemConsumer {
 public:
  virtual ~ProblemConsumer() = default;
  /// Called with the problem before every round (implementations act on the first call only);
  /// throws std::invalid_argument when the problem is not one the optimizer can work on.
  virtual void bind(const Problem& problem) = 0;
};

/// One ask / evaluate / tell round on `problem` (binds a ProblemConsumer first, hands residuals to
/// a ResidualConsumer; throws std::invalid_argument when the optimizer needs residuals and the
/// problem has none). Does nothing when the optimizer is done.
void step(Optimizer& optimizer, const Problem& problem);

/// ||a - b||. A plain loop: GCC 12 reports false -Wmaybe-uninitialized warnings inside Eigen's
/// AVX-512 reductions and min/max.
inline double euclidean_distance(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double sum = 0.0;
  for (Eigen::Index j = 0; j < a.size(); ++j) sum += (a[j] - b[j]) * (a[j] - b[j]);
  return std::sqrt(sum);
}

/// ask/evaluate/tell until done; returns the final result. Throws std::invalid_argument when the
/// problem's box differs from the optimizer's.
const Result& run(Optimizer& optimizer, const Problem& problem);

/// What a caller of run_together() hears about each optimizer (by its index in the span).
class FitnessMemo;  // optimizers/fitness_memo.h

struct TogetherHooks {
  /// Called once when optimizers[i] has finished, in the round it finished (index order within
  /// a round), e.g. to write its result while the others go on.
  std::function<void(std::size_t i)> finished;
  /// When set, an exception from optimizers[i]'s ask, evaluation, tell (or from `finished(i)`)
  /// is handed here and only that optimizer stops; the others go on. When a shared batch
  /// evaluation throws, its slices are evaluated again one by one to find the optimizers at
  /// fault. When unset, the exception propagates out of run_together().
  std::function<void(std::size_t i, std::exception_ptr error)> failed;
  /// Called at the end of each round (after the `finished` calls) with the number of candidates
  /// asked in it (fitness-only and residual batches together), how many of them were scored (the
  /// others repeat a candidate already scored by a deterministic() problem, see FitnessMemo), the
  /// wall time of that scoring and of the whole round (asks, tells and hooks included) [s]. For
  /// performance analysis (`insid bench --round-log`); may be empty.
  std::function<void(std::size_t candidates, std::size_t scored, double scoring_s, double round_s)>
      round_done;
};

/// Advances every optimizer one iteration at a time (lock-step). Per round, the candidates of all
/// unfinished optimizers are scored in a single problem.evaluate_batch() call, those of the
/// ResidualConsumers in a single ResidualProblem::evaluate_residual_batch() call; a
/// ProblemConsumer takes its own step(). Each optimizer is told its slice. A run's result
/// depends only on its own fitness values, so results equal separate run()s whatever the
/// grouping. When the problem is deterministic(), a candidate already scored (in this call, or
/// by earlier calls that were given the same `memo`) is not scored again; the fitness-only
/// batches only. Without a `memo` a fresh one serves this call. Throws std::invalid_argument when
/// a box differs from the problem's; an optimizer that needs residuals on a problem without them
/// fails (see hooks.failed).
void run_together(std::span<Optimizer* const> optimizers, const Problem& problem,
                  const TogetherHooks& hooks = {}, FitnessMemo* memo = nullptr);

}  // namespace insid::opt
