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

#include "identification/grade.h"
#include "identification/ins_problem.h"
#include "nav/fitness.h"
#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid {

struct EkfRtsParams {
  static constexpr std::string_view kAlgorithm = "EKF-RTS";

  double update_interval_s = 1.0;       ///< GNSS updates at most this often (s)
  double propagation_interval_s = 0.1;  ///< covariance propagation step (s)
  int scale_factors = 0;             ///< 1: also estimate gyro and accel scale factors (21 states)
  int use_position = 1;              ///< 1: GNSS position and velocity; 0: velocity only
  double arw_deg_rth = -1.0;         ///< process noise; < 0: the dataset's meta.json noise block
  double vrw_mps_rth = -1.0;         ///< (or the defaults of README when absent)
  double gnss_vel_sigma_mps = -1.0;  ///< measurement noise; < 0: from the dataset
  double gnss_pos_sigma_m = -1.0;
  double initial_bias_sigma = 4.0;    ///< prior std of each bias, catalogue sigma units
  double initial_scale_ppm = 1000.0;  ///< prior std of each scale factor (ppm)

  static std::span<const opt::ParameterField<EkfRtsParams>> fields();
  std::string validate() const;
  opt::ParameterList list() const { return opt::list_parameters(*this); }
  opt::ParameterInfoList info() const { return opt::list_parameter_info(*this); }
  static EkfRtsParams from_map(const opt::ParameterMap& overrides) {
    return opt::parameters_from_map<EkfRtsParams>(overrides);
  }
};

/// The grade-aware set-up (identification/README.md, "EKF-RTS on MEMS data"), used
/// for every grade but nav and for nav with an initial-attitude mode other than gyrocompass
/// (nav with gyrocompass keeps the set-up above, bit for bit):
///   - bias priors initial_bias_sigma x the grade's sigma (not the catalogue's nav sigma);
///   - process and measurement noise from meta.json's noise block, else the IMU random walks
///     measured in the data's flight (data/noise_model.h, estimate_flight_imu_noise: a drone's
///     vibration, which the grade's datasheet figures do not have) and the grade's GNSS levels;
///   - the initial attitude is the navigation problem's initial-attitude mode (level+heading,
///     gyrocompass, given, truth) applied to the data compensated with the current bias
///     estimate, and its error is tied to the bias errors the way that mode ties them:
///     phi0 = G db + w, G = d(attitude)/d(bias) of the mode (finite differences, O(1) each),
///     w the mode's own noise (levelling: VRW / (g sqrt(T)); heading from the GNSS course:
///     sqrt(sum (sigma_v / v_j)^2) / n and ARW sqrt(t_carry); a given heading 1 deg;
///     gyrocompass: the feasibility check's sd; given / truth attitude 1e-3 rad), so
///     P0 = [G Pb G^T + W, G Pb; Pb G^T, Pb] on (phi, biases);
///   - `passes` passes: each one re-aligns with the previous pass's smoothed biases (the
///     levelling tilt of a 20 mg bias is 1.2 deg, the course carried back over 45 s with a
///     0.2 deg/s z-gyro bias 9 deg) and starts from a bias prior centred there with sd =
///     relinearisation_prior_factor x the previous pass's smoothed sd (capped at the grade's
///     prior). The first pass's prior (4 x 0.1 deg/s on the z gyro, i.e. 0.3 rad of heading
///     before the first manoeuvre) is far too wide for the linearised filter: alone it is
///     overconfident (37 of 50 95 % intervals covered on results/mems/'s flights); with the
///     second pass 49 of 50 for factors 10, 30 and 100 alike. The prior then carries ~1/900 of
///     the data's information (factor 30): the data are used twice to that extent, which moves
///     the sd by ~0.06 %. The reported estimate and sd are the last pass's.
struct EkfRtsGradeSetup {
  SensorGrade grade;
  int passes = 2;
  double relinearisation_prior_factor = 30.0;
};
/// The set-up for a navigation problem and grade: nullopt for nav with gyrocompass (the
/// original set-up), else the grade-aware one.
std::optional<EkfRtsGradeSetup> ekf_grade_setup(const NavigationProblem& navigation,
                                                const SensorGrade& grade);

struct EkfRtsResult {
  /// Smoothed estimates at the navigation start (SI, catalogue names: accel_bias_x|y|z,
  /// gyro_bias_x|y|z, with scale_factors also accel_scale_*, gyro_scale_*) and their standard
  /// deviations (SI).
  std::map<std::string, double> estimate, std;
  /// Filtered (forward-only) estimates at the end of the data and their standard deviations.
  std::map<std::string, double> filtered_estimate, filtered_std;
  NoiseLevels noise_used;    ///< process and measurement noise actually used
  std::string noise_source;  ///< where noise_used came from (ekf_rts.cc, ekf_noise_levels)
  int updates = 0;           ///< GNSS updates
  /// The filter's own misfit (last pass): the normalised innovation squared of its GNSS updates,
  /// sum over updates of z^T S^-1 z (z the INS-minus-GNSS innovation, S = H P H^T + R its
  /// covariance as the filter predicts it), over its expected value, the number of scalar
  /// measurements (chi-square with that many degrees of freedom when the filter's noise model is
  /// right; Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4). About 1 when the noise levels are
  /// right; k^2 when every noise the filter assumes is k times too small.
  double nis_per_dof = 0.0;
  int nis_dof = 0;  ///< scalar measurements in that sum
  int states = 15;
  /// Grade-aware set-up only: the grade, the passes and the initial attitude's modelled noise.
  std::optional<EkfRtsGradeSetup> setup;
  double initial_tilt_sd_rad = 0.0, initial_heading_sd_rad = 0.0;
  double filter_wall_s = 0.0;    ///< forward pass (mechanization, covariance, updates)
  double smoother_wall_s = 0.0;  ///< backward RTS pass
  nlohmann::json to_json() const;
};

/// Runs the filter and smoother over `navigation`'s dataset from its navigation start (the
/// attitude of its alignment from the data as recorded, position and velocity from GNSS),
/// starting from the bias values in `base` (usually none).
/// With `setup`, the grade-aware set-up above (the initial attitude then uses the problem's
/// initial-attitude mode on the data compensated with `base`).
EkfRtsResult run_ekf_rts(const NavigationProblem& navigation, const EkfRtsParams& params = {},
                         const SensorErrors& base = {},
                         const std::optional<EkfRtsGradeSetup>& setup = std::nullopt);

/// The filter-smoother as an optimizer of the registry ("ekf-rts", registered by ekf_rts.cc itself
/// for every program that links insid_identification): a ProblemConsumer that
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
  /// The sensor grade, as the caller settled it (identify: settle_grade_and_window). Without
  /// one, the grade of the dataset (grade_for, identification/grade.h). Before bind().
  void set_grade(const SensorGrade& grade) { grade_ = &grade; }
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
  const SensorGrade* grade_ = nullptr;  // a row of the grade table (static storage)
  const opt::Problem* bound_ = nullptr;
  std::optional<EkfRtsResult> ekf_;
  std::vector<std::string> names_;
  Eigen::VectorXd x_, estimate_sigma_, std_sigma_;
  double equivalent_ins_runs_ = 0.0;
};

}  // namespace insid
