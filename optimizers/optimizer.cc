#include "optimizers/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <utility>

#include "optimizers/fitness_memo.h"

namespace insid::opt {

std::string RunConfig::validate() const {
  if (max_iterations < 0) {
    return "run: max_iterations must be >= 0, got " + std::to_string(max_iterations);
  }
  if (max_evaluations < 0) {
    return "run: max_evaluations must be >= 0, got " + std::to_string(max_evaluations);
  }
  if (max_iterations == 0 && max_evaluations == 0) {
    return "run: set max_iterations or max_evaluations (both are 0 = no limit)";
  }
  if (std::isnan(target_fitness)) return "run: target_fitness must not be nan";
  return {};
}

Optimizer::Optimizer(std::string name, Bounds bounds, RunConfig config)
    : bounds_(std::move(bounds)), config_(std::move(config)), rng_(config_.seed) {
  if (std::string error = bounds_.validate(); !error.empty()) throw std::invalid_argument(error);
  if (std::string error = config_.validate(); !error.empty()) throw std::invalid_argument(error);
  result_.algorithm = std::move(name);
  result_.seed = config_.seed;
}

int Optimizer::planned_iterations(int population) const {
  if (config_.max_iterations > 0) return config_.max_iterations;
  return static_cast<int>((config_.max_evaluations + population - 1) / population);
}

void Optimizer::check_initial_positions(int population) const {
  const auto& points = config_.initial_positions;
  if (static_cast<int>(points.size()) > population) {
    throw std::invalid_argument(name() + ": " + std::to_string(points.size()) +
                                " initial positions for a population of " +
                                std::to_string(population));
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!bounds_.contains(points[i])) {
      throw std::invalid_argument(name() + ": initial position " + std::to_string(i) + " " +
                                  format_vector(points[i]) + " is not inside the box");
    }
  }
}

std::vector<Eigen::VectorXd> Optimizer::initial_population(int population) {
  std::vector<Eigen::VectorXd> points;
  points.reserve(population);
  const int n = bounds_.dimension();
  for (int i = 0; i < population; ++i) {
    if (i < static_cast<int>(config_.initial_positions.size())) {
      points.push_back(config_.initial_positions[i]);
      continue;
    }
    Eigen::VectorXd x(n);
    for (int j = 0; j < n; ++j) x[j] = rng_.uniform(bounds_.lower[j], bounds_.upper[j]);
    points.push_back(std::move(x));
  }
  return points;
}

Eigen::VectorXd Optimizer::clamp(const Eigen::VectorXd& x) const {
  Eigen::VectorXd clamped = x;
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    clamped[j] = std::clamp(x[j], bounds_.lower[j], bounds_.upper[j]);
  }
  return clamped;
}

std::span<const Eigen::VectorXd> Optimizer::ask() {
  if (done()) throw std::logic_error(name() + ": ask() after the run has ended");
  if (pending_) return batch_;
  start_clock();

  batch_.clear();
  propose(batch_);
  if (batch_.empty()) throw std::logic_error(name() + ": proposed an empty batch");
  pending_phase_ = phase();

  truncated_ = false;
  if (config_.max_evaluations > 0) {
    const std::int64_t remaining = config_.max_evaluations - result_.evaluations;
    if (static_cast<std::int64_t>(batch_.size()) > remaining) {
      batch_.resize(static_cast<std::size_t>(remaining));  // remaining > 0 while not done
      truncated_ = true;
    }
  }
  pending_ = true;
  return batch_;
}

void Optimizer::tell(std::span<const double> fitness) {
  if (!pending_) throw std::logic_error(name() + ": tell() without a pending ask()");
  if (fitness.size() != batch_.size()) {
    throw std::invalid_argument(name() + ": tell() got " + std::to_string(fitness.size()) +
                                " fitness values for " + std::to_string(batch_.size()) +
                                " candidates");
  }
  check_finite_fitness(batch_, fitness,
                       name() + " iteration " + std::to_string(result_.iterations + 1));

  // Best-so-far first (candidate order; a tie keeps the earlier point), so that accept() sees
  // the global best including this batch.
  for (std::size_t i = 0; i < batch_.size(); ++i) {
    ++result_.evaluations;
    if (fitness[i] < result_.best_f) {
      result_.best_f = fitness[i];
      result_.best_x = batch_[i];
    }
    result_.best_per_evaluation.push_back(result_.best_f);
  }
  if (!truncated_) accept(batch_, fitness);
  ++result_.iterations;
  record_iteration(fitness);
  pending_ = false;

  if (const Termination ends = termination_after(result_.iterations); ends != Termination::kNone) {
    finish(ends);
  } else {
    result_.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - *start_).count();
  }
}

Termination Optimizer::termination_after(int iterations) const {
  if (result_.best_f <= config_.target_fitness) return Termination::kTarget;
  if (config_.max_iterations > 0 && iterations >= config_.max_iterations)
    return Termination::kIterations;
  if (truncated_ || (config_.max_evaluations > 0 && result_.evaluations >= config_.max_evaluations))
    return Termination::kEvaluations;
  return Termination::kNone;
}

void Optimizer::record_iteration(std::span<const double> fitness) {
  IterationRecord record;
  record.iteration = result_.iterations;
  record.evaluations = result_.evaluations;
  record.batch_size = static_cast<int>(batch_.size());
  record.best_fitness = result_.best_f;
  record.phase = pending_phase_;

  std::vector<double> sorted(fitness.begin(), fitness.end());
  std::sort(sorted.begin(), sorted.end());
  const std::size_t half = sorted.size() / 2;
  record.median_fitness =
      sorted.size() % 2 == 1 ? sorted[half] : 0.5 * (sorted[half - 1] + sorted[half]);

  double distance_sum = 0.0;
  for (const Eigen::VectorXd& x : batch_) distance_sum += euclidean_distance(x, result_.best_x);
  record.diversity = distance_sum / static_cast<double>(batch_.size());

  annotate(record);
  if (config_.record_positions) {
    record.positions = batch_;
    record.fitness.assign(fitness.begin(), fitness.end());
  }
  result_.history.push_back(std::move(record));
}

void Optimizer::start_clock() {
  if (!start_) start_ = std::chrono::steady_clock::now();
}

void Optimizer::finish(Termination termination) {
  result_.termination = termination;
  result_.parameters = parameters();
  result_.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - *start_).count();
}

namespace {

void check_same_box(const Optimizer& optimizer, const Problem& problem) {
  const Bounds& a = optimizer.bounds();
  const Bounds& b = problem.bounds();
  if (a.dimension() != b.dimension() || a.lower != b.lower || a.upper != b.upper) {
    throw std::invalid_argument(optimizer.name() +
                                ": the optimizer's box differs from that of "
                                "problem '" +
                                problem.name() + "'");
  }
}

// One ask / evaluate / tell round; a fitness-only batch goes through `memo` when given.
void step_with(Optimizer& optimizer, const Problem& problem, FitnessMemo* memo) {
  if (optimizer.done()) return;
  if (auto* consumer = dynamic_cast<ProblemConsumer*>(&optimizer)) consumer->bind(problem);
  const std::span<const Eigen::VectorXd> batch = optimizer.ask();
  // NaN-filled: a problem that leaves a slot unwritten is caught by tell().
  std::vector<double> fitness(batch.size(), std::numeric_limits<double>::quiet_NaN());
  if (auto* consumer = dynamic_cast<ResidualConsumer*>(&optimizer)) {
    const auto* residual_problem = dynamic_cast<const ResidualProblem*>(&problem);
    if (residual_problem == nullptr) {
      throw std::invalid_argument(optimizer.name() + " needs residual vectors; problem '" +
                                  problem.name() + "' has none");
    }
    std::vector<std::vector<double>> residuals(batch.size());
    residual_problem->evaluate_residual_batch(batch, residuals, fitness);
    consumer->set_residuals(std::move(residuals));
  } else if (memo != nullptr) {
    memo->evaluate_batch(problem, batch, fitness);
  } else {
    problem.evaluate_batch(batch, fitness);
  }
  optimizer.tell(fitness);
}

}  // namespace

void step(Optimizer& optimizer, const Problem& problem) { step_with(optimizer, problem, nullptr); }

const Result& run(Optimizer& optimizer, const Problem& problem) {
  check_same_box(optimizer, problem);
  std::optional<FitnessMemo> memo;
  if (problem.deterministic()) memo.emplace();
  while (!optimizer.done()) step_with(optimizer, problem, memo ? &*memo : nullptr);
  return optimizer.result();
}

namespace {

// The candidates of one lock-step round that are scored together, and whose they are.
struct SharedBatch {
  std::vector<Eigen::VectorXd> candidates;
  std::vector<std::pair<std::size_t, std::size_t>> slices;  // optimizer index, its batch size
  void clear() {
    candidates.clear();
    slices.clear();
  }
  void add(std::size_t i, std::span<const Eigen::VectorXd> xs) {
    candidates.insert(candidates.end(), xs.begin(), xs.end());
    slices.emplace_back(i, xs.size());
  }
};

}  // namespace

void run_together(std::span<Optimizer* const> optimizers, const Problem& problem,
                  const TogetherHooks& hooks, FitnessMemo* memo) {
  for (const Optimizer* optimizer : optimizers) check_same_box(*optimizer, problem);
  const auto* residual_problem = dynamic_cast<const ResidualProblem*>(&problem);
  // Finished or failed: not advanced. Optimizers done on entry are not reported.
  std::vector<char> stopped(optimizers.size());
  for (std::size_t i = 0; i < optimizers.size(); ++i) stopped[i] = optimizers[i]->done();
  // Called inside a catch block: hands the exception to the hook, or rethrows it.
  const auto fail = [&](std::size_t i) {
    if (!hooks.failed) throw;
    stopped[i] = 1;
    hooks.failed(i, std::current_exception());
  };

  // Scores a round's batch (with the residual vectors when `with_residuals`) and tells each
  // optimizer its slice. When the batch fails and failures are isolated, the slices are scored
  // one by one to find the optimizer(s) at fault; the others carry on.
  std::vector<double> fitness;
  std::vector<std::vector<double>> residuals;
  std::optional<FitnessMemo> own_memo;  // a repeated candidate is scored once
  if (!problem.deterministic())
    memo = nullptr;
  else if (memo == nullptr)
    memo = &own_memo.emplace();
  std::size_t scored = 0;  // this round
  const auto score = [&](const SharedBatch& batch, bool with_residuals) {
    if (batch.slices.empty()) return;
    const std::size_t n = batch.candidates.size();
    // NaN-filled: a problem that leaves a slot unwritten is caught by tell().
    fitness.assign(n, std::numeric_limits<double>::quiet_NaN());
    residuals.assign(with_residuals ? n : 0, {});
    const auto evaluate = [&](std::size_t offset, std::size_t size) {
      const auto xs = std::span<const Eigen::VectorXd>(batch.candidates).subspan(offset, size);
      const auto f = std::span<double>(fitness).subspan(offset, size);
      if (with_residuals) {
        residual_problem->evaluate_residual_batch(
            xs, std::span<std::vector<double>>(residuals).subspan(offset, size), f);
      } else {
        problem.evaluate_batch(xs, f);
      }
    };
    try {
      if (memo != nullptr && !with_residuals) {
        scored += memo->evaluate_batch(problem, batch.candidates, fitness);
      } else {
        evaluate(0, n);
        scored += n;
      }
    } catch (...) {
      if (!hooks.failed) throw;
      std::size_t offset = 0;
      for (const auto& [i, size] : batch.slices) {
        try {
          scored += size;
          evaluate(offset, size);
        } catch (...) {
          fail(i);
        }
        offset += size;
      }
    }
    std::size_t offset = 0;
    for (const auto& [i, size] : batch.slices) {
      if (!stopped[i]) {
        try {
          if (with_residuals) {
            const auto first = residuals.begin() + static_cast<std::ptrdiff_t>(offset);
            dynamic_cast<ResidualConsumer&>(*optimizers[i])
                .set_residuals(std::vector<std::vector<double>>(
                    std::make_move_iterator(first),
                    std::make_move_iterator(first + static_cast<std::ptrdiff_t>(size))));
          }
          optimizers[i]->tell(std::span<const double>(fitness).subspan(offset, size));
        } catch (...) {
          fail(i);
        }
      }
      offset += size;
    }
  };

  SharedBatch plain, least_squares;  // fitness-only candidates; candidates whose residuals count
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
  };
  for (;;) {
    const Clock::time_point t_round = Clock::now();
    // One round: ProblemConsumers take their own step; the others ask for their next batch, all
    // fitness-only batches are scored in one evaluate_batch call, all residual batches in one
    // evaluate_residual_batch call.
    plain.clear();
    least_squares.clear();
    for (std::size_t i = 0; i < optimizers.size(); ++i) {
      if (stopped[i]) continue;
      Optimizer& optimizer = *optimizers[i];
      try {
        if (dynamic_cast<ProblemConsumer*>(&optimizer) != nullptr) {
          step(optimizer, problem);
        } else if (dynamic_cast<ResidualConsumer*>(&optimizer) != nullptr) {
          if (residual_problem == nullptr) {
            throw std::invalid_argument(optimizer.name() + " needs residual vectors; problem '" +
                                        problem.name() + "' has none");
          }
          least_squares.add(i, optimizer.ask());
        } else {
          plain.add(i, optimizer.ask());
        }
      } catch (...) {
        fail(i);
      }
    }
    const Clock::time_point t_scoring = Clock::now();
    scored = 0;
    score(plain, false);
    score(least_squares, true);
    const double scoring_s = seconds_since(t_scoring);
    bool all_stopped = true;
    for (std::size_t i = 0; i < optimizers.size(); ++i) {
      if (stopped[i]) continue;
      if (!optimizers[i]->done()) {
        all_stopped = false;
        continue;
      }
      stopped[i] = 1;
      if (hooks.finished) {
        try {
          hooks.finished(i);
        } catch (...) {
          fail(i);
        }
      }
    }
    if (hooks.round_done)
      hooks.round_done(plain.candidates.size() + least_squares.candidates.size(), scored, scoring_s,
                       seconds_since(t_round));
    if (all_stopped) return;
  }
}

}  // namespace insid::opt
