// Kalman filter-smoother baseline (`--algo ekf-rts`): a loosely coupled INS/GNSS error-state
// extended Kalman filter with closed-loop feedback and a Rauch-Tung-Striebel smoother, run once
// over the same dataset the optimizers identify from. Its bias estimates (and their standard
// deviations) are reported in the same result JSON. Model, noise and choices:
// identification/README.md "Kalman filter-smoother baseline (ekf-rts)" and ekf_rts.cc.
#pragma once

#include <chrono>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/fitness.h"
#include "identification/ins_problem.h"
#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid {

struct EkfRtsParams {
  static constexpr std::string_view kAlgorithm = "EKF-RTS";

  double update_interval_s = 1.0;     ///< GNSS updates at most this often (s)
  double propagation_interval_s = 0.1;  ///< covariance propagation step (s)
  int scale_factors = 0;              ///< 1: also estimate gyro and accel scale factors (21 states)
  int use_position = 1;               ///< 1: GNSS position and velocity; 0: velocity only
  double arw_deg_rth = -1.0;          ///< process noise; < 0: the dataset's meta.json noise block
  double vrw_mps_rth = -1.0;          ///< (or the defaults of README when absent)
  double gnss_vel_sigma_mps = -1.0;   ///< measurement noise; < 0: from the dataset
  double gnss_pos_sigma_m = -1.0;
  double initial_bias_sigma = 4.0;    ///< prior std of each bias, catalogue sigma units
  double initial_scale_ppm = 1000.0;  ///< prior std of each scale factor (ppm)

  static std::span<const opt::ParameterField<EkfRtsParams>> fields();
  std::string validate() const;
  opt::ParameterList list() const { return opt::list_parameters(*this); }
  static EkfRtsParams from_map(const opt::ParameterMap& overrides) {
    return opt::parameters_from_map<EkfRtsParams>(overrides);
  }
};

struct EkfRtsResult {
  /// Smoothed estimates at the navigation start (SI, catalogue names: accel_bias_x|y|z,
  /// gyro_bias_x|y|z, with scale_factors also accel_scale_*, gyro_scale_*) and their standard
  /// deviations (SI).
  std::map<std::string, double> estimate, std;
  /// Filtered (forward-only) estimates at the end of the data and their standard deviations.
  std::map<std::string, double> filtered_estimate, filtered_std;
  NoiseLevels noise_used;  ///< process and measurement noise actually used
  int updates = 0;         ///< GNSS updates
  int states = 15;
  double filter_wall_s = 0.0;    ///< forward pass (mechanization, covariance, updates)
  double smoother_wall_s = 0.0;  ///< backward RTS pass
  nlohmann::json to_json() const;
};

/// Runs the filter and smoother over `navigation`'s dataset from its navigation start (the
/// attitude of its alignment from the data as recorded, position and velocity from GNSS),
/// starting from the bias values in `base` (usually none).
EkfRtsResult run_ekf_rts(const NavigationProblem& navigation, const EkfRtsParams& params = {},
                         const SensorErrors& base = {});

/// The filter-smoother as an optimizer of the registry ("ekf-rts"): a ProblemConsumer that
/// runs on the InsIdentificationProblem it is bound to, then asks for exactly one evaluation,
/// its own estimate (clamped to the box), so the result has the Eq. 15 fitness of the estimate;
/// the run ends after that one iteration. parameters() lists the settings and, after the run,
/// `equivalent_ins_runs` (filter + smoother wall time over the wall time of one scalar INS run
/// of the estimate on the calling thread, timed in bind(): independent of the thread count and
/// of a campaign's lock-step batches), `filter_smoother_wall_s` and `std_sigma_<name>` of every
/// estimated parameter. The run's wall clock starts at bind(), so Result::wall_time_s includes
/// the filter pass and the yardstick run.
class EkfRtsOptimizer final : public opt::Optimizer, public opt::ProblemConsumer {
 public:
  EkfRtsOptimizer(const opt::Bounds& bounds, const opt::RunConfig& config,
                  const EkfRtsParams& params = {});
  opt::ParameterList parameters() const override;
  void bind(const opt::Problem& problem) override;
  /// The filter's output (after bind()).
  const std::optional<EkfRtsResult>& ekf() const { return ekf_; }
  /// Estimate and standard deviation of the problem's parameters, sigma units.
  const Eigen::VectorXd& estimate_sigma() const { return estimate_sigma_; }
  const Eigen::VectorXd& std_sigma() const { return std_sigma_; }
  double equivalent_ins_runs() const { return equivalent_ins_runs_; }
  /// Block for the identify JSON: estimate_std_sigma, all bias estimates, cost, settings.
  nlohmann::json report_json(const ParameterMapping& mapping) const;

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return "filter-smoother"; }

 private:
  EkfRtsParams params_;
  const opt::Problem* bound_ = nullptr;
  std::optional<EkfRtsResult> ekf_;
  std::vector<std::string> names_;
  Eigen::VectorXd x_, estimate_sigma_, std_sigma_;
  double equivalent_ins_runs_ = 0.0;
};

/// Registers "ekf-rts" with the optimizer registry (idempotent). Call before make_optimizer /
/// optimize / parse_campaign use the name (insid's main does).
void register_ekf_rts();

}  // namespace insid
