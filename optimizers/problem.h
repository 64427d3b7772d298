// The optimizers' view of a problem: a box and a batch evaluation that scores a whole
// population at once (docs/design.md sec. 6). Nothing here knows about INS.
//
// Coordinates. Optimizers search the problem's own box. By convention a problem presents a
// normalised box, [-1, 1]^n; every distance an optimizer uses (DVPIO's d and dist_threshold,
// the diversity in the history) is in these coordinates.
//
// Two ways to write a problem:
//  - derive from Problem and implement evaluate_batch() (e.g. a vectorised multi-candidate
//    kernel that advances all candidates in lock-step);
//  - derive from ScalarProblem and implement fitness() for one candidate, or wrap a callable in
//    FunctionProblem; the batch is then run serially or with OpenMP across candidates.
#pragma once

#include <functional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace insid::opt {

/// Axis-aligned search box.
struct Bounds {
  Eigen::VectorXd lower;  ///< lower corner
  Eigen::VectorXd upper;  ///< upper corner

  /// [-1, 1]^n, the normalised box.
  static Bounds unit_box(int dimension);

  int dimension() const { return static_cast<int>(lower.size()); }
  Eigen::VectorXd width() const { return upper - lower; }
  /// Empty when valid (n >= 1, equal sizes, finite, lower < upper), else the reason.
  std::string validate() const;
  bool contains(const Eigen::VectorXd& x) const;
};

/// Base of the errors raised while scoring candidates.
class EvaluationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A fitness that is NaN or infinite. The message names the candidate and its coordinates.
class NonFiniteFitnessError : public EvaluationError {
 public:
  using EvaluationError::EvaluationError;
};

/// Throws NonFiniteFitnessError for the first candidate i with a non-finite f[i]:
/// "<context>: non-finite fitness nan for candidate 3 at x = [0.1, 0.2]".
void check_finite_fitness(std::span<const Eigen::VectorXd> xs, std::span<const double> f,
                          const std::string& context);

class Problem {
 public:
  explicit Problem(Bounds bounds);  ///< throws std::invalid_argument on an invalid box
  virtual ~Problem() = default;

  int dimension() const { return bounds_.dimension(); }
  const Bounds& bounds() const { return bounds_; }
  virtual std::string name() const { return "problem"; }

  /// Scores every candidate: f_out[i] = fitness(xs[i]), f_out.size() == xs.size(). Minimised.
  /// Must not depend on the order or grouping of candidates (a campaign runner concatenates
  /// the populations of several runs into one batch). Errors are reported by exception.
  virtual void evaluate_batch(std::span<const Eigen::VectorXd> xs,
                              std::span<double> f_out) const = 0;

  /// True when the fitness is a function of x's bits alone: the same x scores the same value,
  /// bit for bit, in any batch, position or thread count. run() and run_together() then score a
  /// repeated candidate once (FitnessMemo). False unless a problem says so.
  virtual bool deterministic() const { return false; }

 private:
  Bounds bounds_;
};

enum class Parallelism {
  kSerial,  ///< candidates one after the other on the calling thread
  kOpenMP,  ///< an OpenMP parallel loop over candidates
};

struct EvaluatorOptions {
  Parallelism parallelism = Parallelism::kSerial;
  int num_threads = 0;  ///< OpenMP threads; 0 = the OpenMP default

  /// "" when valid, else why, naming the value: num_threads below 0.
  std::string validate() const;
  /// *this, or std::invalid_argument with validate()'s reason (for constructors).
  const EvaluatorOptions& validated() const;
  /// The threads a batch is scored on: 1 serially; with OpenMP num_threads, or the OpenMP
  /// default when it is 0.
  int threads() const;
};

/// The per-candidate evaluator: f_out[i] = fitness(xs[i]) serially or with OpenMP. An
/// exception thrown by `fitness` never leaves the parallel region: it is caught, recorded per
/// candidate, and after the loop the one of the lowest candidate index is rethrown as an
/// EvaluationError naming the candidate, with the original nested (std::throw_with_nested).
void evaluate_each(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                   const EvaluatorOptions& options,
                   const std::function<double(const Eigen::VectorXd&)>& fitness);

/// A problem defined by a single-candidate fitness, batched by evaluate_each().
class ScalarProblem : public Problem {
 public:
  explicit ScalarProblem(Bounds bounds, EvaluatorOptions options = {});

  /// Fitness of one candidate. Must be thread-safe when the evaluator is OpenMP.
  virtual double fitness(const Eigen::VectorXd& x) const = 0;

  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f_out) const final;

  const EvaluatorOptions& evaluator() const { return options_; }
  void set_evaluator(const EvaluatorOptions& options) { options_ = options.validated(); }

 private:
  EvaluatorOptions options_;
};

/// Optional second interface of a problem whose fitness is built from a residual vector (the
/// least-squares baselines, e.g. "lm", need it). One residual evaluation costs what one fitness
/// evaluation costs (one full run of the model) and yields the fitness of the same point too.
class ResidualProblem {
 public:
  virtual ~ResidualProblem() = default;
  /// Length of the residual vector (the same for every x).
  virtual int residual_count() const = 0;
  /// r_out[i] = residual vector at xs[i] (resized to residual_count()), f_out[i] = fitness at
  /// xs[i] from the same run. Same ordering/grouping rules as Problem::evaluate_batch.
  virtual void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                                       std::span<std::vector<double>> r_out,
                                       std::span<double> f_out) const = 0;
};

/// A ScalarProblem wrapping a callable.
class FunctionProblem final : public ScalarProblem {
 public:
  using Function = std::function<double(const Eigen::VectorXd&)>;

  FunctionProblem(Bounds bounds, Function function, EvaluatorOptions options = {},
                  std::string name = "function");

  double fitness(const Eigen::VectorXd& x) const override { return function_(x); }
  std::string name() const override { return name_; }

 private:
  Function function_;
  std::string name_;
};

}  // namespace insid::opt
