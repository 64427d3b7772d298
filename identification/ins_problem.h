// The INS identification problem for the generic optimizers: a normalised box [-1, 1]^n
// mapped to catalogue effects in SI units, scored by a full alignment + pure-INS run
// (nav/fitness.h, Eq. 15 by default). The optimizers know nothing of this mapping.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "kernel/batch_fitness.h"
#include "model/sensor_errors.h"
#include "nav/fitness.h"
#include "nav/gyro_at_rest.h"
#include "optimizers/parameters.h"
#include "optimizers/problem.h"

namespace insid {

/// One estimated effect: catalogue name, its sigma (search unit, SI) and box in sigma units.
struct EstimatedParameter {
  std::string name;
  double sigma = 0.0;         ///< SI value of one sigma
  double lower_sigma = -4.0;  ///< box, in sigma units (docs/design.md sec. 2: [-4, 4])
  double upper_sigma = 4.0;

  /// "NAME" (catalogue sigma, [-4, 4]) or "NAME:SIGMA" or "NAME:SIGMA:LO:HI" (SIGMA in SI,
  /// LO/HI in sigma units). Throws std::invalid_argument naming the bad part.
  static EstimatedParameter parse(const std::string& text);
  /// The paper's four: accel_bias_x, accel_bias_y, gyro_bias_x, gyro_bias_y (docs/design.md sec.
  /// 2).
  static std::vector<EstimatedParameter> paper_four();
};

/// Maps between the optimizer's normalised coordinates x in [-1, 1]^n, sigma units and SI.
class ParameterMapping {
 public:
  /// `gyro_at_rest`: the gyro biases b0 are not searched but measured at rest (nav/
  /// gyro_at_rest.h): every candidate gets the b0 that makes the static window's compensated
  /// rate the Earth rate, given its other gyro terms (drift, scale, misalignment, motor offset).
  /// Throws std::invalid_argument when a gyro_bias_* is estimated as well.
  explicit ParameterMapping(std::vector<EstimatedParameter> parameters, SensorErrors base = {},
                            std::optional<GyroAtRest> gyro_at_rest = std::nullopt);
  int dimension() const { return static_cast<int>(parameters_.size()); }
  const std::vector<EstimatedParameter>& parameters() const { return parameters_; }
  const SensorErrors& base() const { return base_; }
  const std::optional<GyroAtRest>& gyro_at_rest() const { return gyro_at_rest_; }
  /// The same mapping with another rest measurement (a noise replica's window).
  ParameterMapping with_gyro_at_rest(const GyroAtRest& rest) const;

  Eigen::VectorXd to_sigma(const Eigen::VectorXd& x) const;
  Eigen::VectorXd from_sigma(const Eigen::VectorXd& value_sigma) const;
  /// Base errors with the estimated effects set to their SI values (base values replaced).
  SensorErrors to_errors(const Eigen::VectorXd& x) const;
  /// Sigma-unit distance that one normalised unit spans in dimension j.
  double sigma_per_unit(int j) const;
  /// An algorithm parameter as the optimizer takes it. `own`: the algorithm's parameters with
  /// their units (opt::parameter_info). `NAME_sigma` for a parameter NAME whose unit is
  /// opt::ParameterUnit::kBoxDistance (DVPIO's `d_initial_sigma=0.05`) is that distance in sigma
  /// units: returned as NAME, divided by the sigma span of one normalised unit. Any other key
  /// comes back unchanged (ekf-rts's own `initial_bias_sigma`, a prior in catalogue sigma units,
  /// included). Throws std::invalid_argument naming the key when the estimated parameters' boxes
  /// differ in width (no common unit).
  std::pair<std::string, double> algorithm_parameter_in_box(
      std::string key, double value, const opt::ParameterInfoList& own) const;

 private:
  std::vector<EstimatedParameter> parameters_;
  SensorErrors base_;
  std::optional<GyroAtRest> gyro_at_rest_;
};

/// Which implementation scores candidates (docs/design.md sec. 8).
enum class FitnessEvaluator {
  kBatched,  ///< the vectorised multi-candidate kernel (kernel/batch_fitness.h); default
  kScalar,   ///< NavigationProblem::fitness per candidate (the reference), for comparison
};

class InsIdentificationProblem final : public opt::Problem, public opt::ResidualProblem {
 public:
  /// `evaluator`: threads for a batch. With the batched kernel, kOpenMP spreads groups of
  /// candidate vectors over num_threads threads (0 = the OpenMP default) and kSerial uses the
  /// calling thread; with the scalar reference it is evaluate_each's per-candidate loop.
  InsIdentificationProblem(std::shared_ptr<const NavigationProblem> navigation,
                           ParameterMapping mapping, FitnessKind kind = FitnessKind::kEq15,
                           opt::EvaluatorOptions evaluator = {},
                           FitnessEvaluator implementation = FitnessEvaluator::kBatched);
  /// Scores a batch with the batched kernel (falls back to the scalar reference when the data are
  /// outside what the kernel covers, see BatchFitness::supported()). Results do not depend on the
  /// thread count or on how the candidates are grouped; a candidate whose set-up fails (e.g.
  /// alignment) is reported as opt::EvaluationError naming it, as evaluate_each does.
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f_out) const override;
  /// True: both implementations score a candidate from its bits alone (the batched kernel's
  /// lanes do not depend on their neighbours, grouping or thread count), so a repeated candidate
  /// is scored once by opt::run and opt::run_together (opt::FitnessMemo).
  bool deterministic() const override { return true; }
  /// Fitness of one candidate with the scalar reference.
  double fitness(const Eigen::VectorXd& x) const;
  /// Residual vector (dvE_t, dvN_t) of NavigationProblem::residuals, for the least-squares
  /// baselines ("lm"); one full INS run per point, the fitness of `kind` from the same run.
  int residual_count() const override;
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r_out,
                               std::span<double> f_out) const override;
  std::string name() const override { return "ins-identification"; }
  const ParameterMapping& mapping() const { return mapping_; }
  const NavigationProblem& navigation() const { return *navigation_; }

  const opt::EvaluatorOptions& evaluator() const { return options_; }
  void set_evaluator(const opt::EvaluatorOptions& options) { options_ = options.validated(); }
  FitnessEvaluator implementation() const { return implementation_; }
  /// True when batches go through the batched kernel (kBatched and data supported).
  bool uses_batched_kernel() const;

 private:
  // Scores (score) and then refuses a non-finite fitness (require_finite): NonFiniteFitnessError
  // naming the candidate's parameters in SI and sigma and the IMU or GNSS line where its
  // navigation became non-finite.
  void evaluate(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                std::span<std::vector<double>> r_out) const;
  void score(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
             std::span<std::vector<double>> r_out) const;
  void require_finite(std::span<const Eigen::VectorXd> xs, std::span<const double> f) const;

  std::shared_ptr<const NavigationProblem> navigation_;
  std::shared_ptr<const BatchFitness> kernel_;
  ParameterMapping mapping_;
  FitnessKind kind_;
  opt::EvaluatorOptions options_;
  FitnessEvaluator implementation_;
};

}  // namespace insid
