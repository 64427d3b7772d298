// How sure an identification is: one implementation for every algorithm,
// whatever found the point (swarm, baseline, LM, EKF-RTS).
//
//   * Jacobian J = d r / d value_sigma of the residual vector (dvE_t, dvN_t) at the estimate,
//     central differences through the problem's batched kernel (2n candidates in one batch).
//   * Noise model: noise replicas of the flight (the levels and the noise model of
//     data/noise_model.h, generated in place per thread for speed). The INS residuals are
//     integrated ARW/VRW plus the alignment error propagated through Schuler dynamics: strongly
//     correlated and not stationary, so neither s^2 (J^T J)^-1 (white) nor a stationary
//     autocorrelation (HAC) sandwich describes them. A replica = the dataset with extra white
//     noise of the data's own levels on every IMU increment and GNSS epoch, run through the same
//     pipeline (alignment included) at the estimate; replica minus data run = one draw d_m of
//     the residuals' noise response. The least-squares estimator's response to it is
//     dtheta_m = -(J^T J)^-1 J^T d_m, and the covariance is the mean of dtheta_m dtheta_m^T over
//     the replicas (a sandwich (J^T J)^-1 J^T Sigma_r J (J^T J)^-1 with Sigma_r estimated by the
//     replicas, never formed).
//   * Distance to the optimum: one Gauss-Newton step from the estimate on the criterion the
//     algorithm minimised (least squares, or an IRLS/Weiszfeld step for Eq. 15's sum of norms),
//     parameters held at a box edge they press against; in sd units per parameter.
//   * Flags per parameter: at_box_edge, not_observable, correlated:<other>, not_converged; a
//     not_converged estimate's sd is sqrt(sd^2 + step^2) (it covers the optimum too).
//   * EKF-RTS: its own smoothed sd, scaled by its innovations' misfit (use_filter_sd).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "base/enum_table.h"
#include "data/dataset.h"
#include "identification/ins_problem.h"
#include "optimizers/optimizer.h"

namespace insid {

/// What the algorithm that found the point minimised (sets the Gauss-Newton step used for the
/// distance to the optimum).
enum class UncertaintyCriterion {
  kEq15,          ///< Eq. 15 sum of norms (GA, PSO, PIO, DVPIO, CMA-ES, DE, ... ): IRLS step
  kLeastSquares,  ///< sum of squares of the residuals (lm, ekf-rts): Gauss-Newton step
};
/// The names written to the uncertainty block ("criterion").
inline constexpr EnumTable<UncertaintyCriterion, 2> kUncertaintyCriterionNames{
    "uncertainty criterion",
    {{{UncertaintyCriterion::kEq15, "eq15"},
      {UncertaintyCriterion::kLeastSquares, "least-squares"}}}};
inline std::string to_string(UncertaintyCriterion criterion) {
  return std::string(kUncertaintyCriterionNames.name(criterion));
}
/// The criterion an algorithm of the registry minimises (its least_squares trait, registry.h).
/// Throws std::invalid_argument for an unknown algorithm.
UncertaintyCriterion criterion_for_algorithm(const std::string& algorithm);

struct UncertaintyOptions {
  int replicas = 100;             ///< noise replicas (sd's own relative error ~1/sqrt(2M))
  std::uint64_t seed = 20261124;  ///< replica noise seed
  /// Central-difference step in sigma units. The residuals are close to linear in the sensor
  /// errors over several sigma; 0.01 sigma keeps the truncation error (h^2) negligible and the
  /// difference (~1e-2 of a sigma's effect, itself >> the 1e-12 relative kernel round-off) clean.
  double jacobian_step_sigma = 0.01;
  UncertaintyCriterion criterion = UncertaintyCriterion::kEq15;
  /// not_observable when the 95 % interval (2 x 1.96 sd) is wider than this fraction of the
  /// search box: the flight cannot place the parameter inside the box it was searched in.
  double not_observable_box_fraction = 1.0;
  /// not_observable when the share of the parameter's Jacobian column not explained by the other
  /// columns, |P_perp J_j|^2 / |J_j|^2, is below this (absorbed by the others).
  double absorbed_share = 1e-4;
  double correlated_threshold = 0.95;  ///< |rho| above this: correlated:<other>
  double not_converged_sd = 1.0;       ///< GN step to the optimum beyond this many sd
  double box_edge_tolerance = 1e-3;    ///< at_box_edge within this fraction of the box width
  /// Model misfit: when the residual the parameters cannot absorb is above every noise
  /// replica's and its mean square exceeds the replicas' by more than this ratio, the covariance
  /// is scaled by the ratio (see estimate_uncertainty). >= 1.
  double misfit_min_ratio = 4.0;
  int threads = 0;  ///< replica runs in parallel (0 = OpenMP default)
  /// Noise levels of the replicas; default: meta.json "noise", else estimated from the data.
  std::optional<NoiseLevels> noise;
  /// Why the options are unusable ("" when they are), naming the field and value.
  std::string validate() const;
};

struct ParameterUncertainty {
  std::string name;
  double sigma_si = 0.0;  ///< SI value of one sigma unit (the search unit)
  double estimate_si = 0.0;
  std::optional<double> sd_si;  ///< empty when it cannot be computed (sd_reason says why)
  std::string sd_reason;
  /// Where sd comes from: "gauss-newton replicas" (estimate_uncertainty), or the algorithm's
  /// own covariance ("ekf-rts smoothed covariance", use_filter_sd), with the Gauss-Newton
  /// value then kept in sd_gauss_newton_si for comparison.
  std::string sd_source = "gauss-newton replicas";
  std::optional<double> sd_gauss_newton_si;
  std::string unit, unit_eng;                ///< SI unit, engineering unit (deg/h, ug, ppm, ...)
  double eng_per_si = 1.0;                   ///< engineering value = SI value * eng_per_si
  double share_not_absorbed = 0.0;           ///< |P_perp J_j|^2 / |J_j|^2 (1 = independent column)
  double box_width_sigma = 0.0;              ///< search box width (sigma units)
  double step_to_optimum_sigma = 0.0;        ///< GN step (sigma units)
  std::optional<double> step_to_optimum_sd;  ///< |step| / sd (the sd before the step is added)
  /// not_converged: the sd before the step to the optimum was added to it (sd_si is then
  /// sqrt(sd^2 + step^2), see estimate_uncertainty); empty otherwise.
  std::optional<double> sd_without_step_si;
  /// EKF-RTS: the smoother's own sd as the filter computed it, before its misfit scale.
  std::optional<double> sd_filter_si;
  std::vector<std::string> flags;
  double estimate_sigma_units() const { return estimate_si / sigma_si; }
};

/// Model misfit as a Birge ratio: the part of a residual r that the columns of J cannot absorb,
/// |P_perp r|^2, against the same part of noise replica responses (the columns of D),
/// mean_k |P_perp d_k|^2. With the model right and the noise at the replicas' levels the two
/// have the same distribution; a flight whose residual is far above every replica has structure
/// the model lacks (an effect not estimated, a wrong noise level), and a noise-only covariance
/// is then too small by about that ratio (Particle Data Group, "Review of Particle Physics",
/// Introduction, "Averages and fits": the scale factor S = sqrt(chi^2 / dof), applied when S > 1).
struct MisfitRatio {
  std::optional<double> residual_vs_noise_rms;  ///< sqrt of the ratio; none without noise
  bool residual_above_every_replica = false;
  /// sqrt(ratio) when the residual exceeds every replica's and the ratio exceeds `min_ratio`,
  /// else 1: the factor on every noise-only sd.
  double sd_scale = 1.0;
  double covariance_scale = 1.0;  ///< the ratio itself where sd_scale is its root, else 1
};
MisfitRatio misfit_ratio(const Eigen::MatrixXd& J, const Eigen::VectorXd& r,
                         const Eigen::MatrixXd& D, double min_ratio);

struct UncertaintyReport {
  std::vector<ParameterUncertainty> parameters;
  Eigen::MatrixXd covariance_sigma;  ///< sigma units (NaN rows/cols where sd is missing)
  Eigen::MatrixXd correlation;       ///< NaN where undefined
  Eigen::MatrixXd jacobian_sigma;    ///< d r / d value_sigma at the estimate (m/s per sigma)
  Eigen::VectorXd residuals;         ///< r at the estimate (m/s)
  std::optional<double> distance_to_optimum_sd;  ///< max over parameters of |step| / sd
  /// sqrt(|P_perp r|^2 / mean_k |P_perp d_k|^2): the unabsorbed residual against the noise
  /// replicas' (about 1 when the model and the noise levels are right).
  std::optional<double> residual_vs_noise_rms;
  bool residual_above_every_replica = false;
  double sd_scale = 1.0;  ///< factor applied to every sd for model misfit (1: none)
  /// EKF-RTS (use_filter_sd): the filter's own misfit, its innovations' normalised squares per
  /// degree of freedom (EkfRtsResult::nis_per_dof), their count, and the factor its sd got.
  std::optional<double> filter_nis_per_dof;
  int filter_nis_dof = 0;
  double filter_sd_scale = 1.0;
  /// nis_per_dof > options.misfit_min_ratio: the filter's noise model is far off, and its sd is
  /// then never below the Gauss-Newton sd at its point (use_filter_sd).
  bool filter_model_rejected = false;
  UncertaintyCriterion criterion = UncertaintyCriterion::kEq15;
  NoiseLevels noise_levels;
  std::string noise_source;
  int replicas = 0;
  double jacobian_step_sigma = 0.0;
  std::int64_t evaluations = 0;  ///< full INS runs (Jacobian + replicas)
  double wall_s = 0.0;
  /// The replicas came from a shared NoiseReplicaSet run at replicas_at_sigma (their runs are
  /// not in `evaluations`).
  bool replicas_shared = false;
  Eigen::VectorXd replicas_at_sigma;
  UncertaintyOptions options;
  /// "parameters": [{name, estimate, sd, unit, estimate_eng, sd_eng, unit_eng, flags, ...}].
  nlohmann::json parameters_json() const;
  /// "correlation": {names, matrix} (null where undefined).
  nlohmann::json correlation_json() const;
  /// "uncertainty": method, noise model, thresholds, distance to the optimum, cost.
  nlohmann::json method_json() const;
  /// A short human table (one line per parameter, then the strong correlations).
  std::string table() const;
};

/// Engineering unit of a catalogue SI unit: "rad/s" -> deg/h, "m/s^2" -> ug, "1" -> ppm,
/// "rad" -> arcsec, "m/s^3" -> ug/h, "rad/s^2" -> deg/h^2, "s" -> ms, "m" -> m.
/// Returns the unit and the factor (engineering = SI * factor).
std::pair<std::string, double> engineering_unit(const std::string& si_unit);

/// The noise replicas' responses of one dataset (replica run minus data run, m x M, m/s) at one
/// point: what estimate_uncertainty needs from the replicas. They depend on the data and the
/// noise model, and only weakly on the point (linear regime), so a campaign computes them once
/// per scenario (at the data's optimum) and every run adds only its own Jacobian.
struct NoiseReplicaSet {
  Eigen::MatrixXd responses;  ///< m x M (m/s)
  Eigen::VectorXd at_sigma;   ///< the point the replicas were run at (sigma units)
  NoiseLevels levels;
  std::string source;
  std::uint64_t seed = 0;
  std::int64_t evaluations = 0;  ///< full INS runs (data + replicas)
  double wall_s = 0.0;
};

/// Runs options.replicas noise replicas of `problem`'s data at `at_sigma` (options.seed, noise
/// levels and threads as estimate_uncertainty uses them).
NoiseReplicaSet noise_replica_set(const InsIdentificationProblem& problem,
                                  const Eigen::VectorXd& at_sigma,
                                  const UncertaintyOptions& options = {});

/// The uncertainty of the estimate `value_sigma` (sigma units) of `problem`. With `shared`
/// (noise_replica_set of the same data) the replicas are not run again: the run costs its
/// Jacobian (2n + 1 batched runs) and one scalar run; with the set run at `value_sigma` itself
/// the result equals the call without it.
UncertaintyReport estimate_uncertainty(const InsIdentificationProblem& problem,
                                       const Eigen::VectorXd& value_sigma,
                                       const UncertaintyOptions& options = {},
                                       const NoiseReplicaSet* shared = nullptr);

/// What the EKF-RTS says about its own estimate (EkfRtsOptimizer after its run).
struct FilterSd {
  std::vector<double> sd_si;  ///< the smoother's sd per parameter, the report's order (SI)
  double nis_per_dof = 1.0;   ///< EkfRtsResult::nis_per_dof (innovations' chi-square / dof)
  int nis_dof = 0;            ///< EkfRtsResult::nis_dof
};

/// EKF-RTS: parameters[].sd becomes the filter-smoother's own sd, made honest (identification/
/// README.md, "How sure an estimate is"): the smoothed sd times the filter's own Birge ratio
/// report.filter_sd_scale = sqrt(max(1, NIS/dof)) of its innovations; when NIS/dof exceeds
/// options.misfit_min_ratio (its noise model rejected, report.filter_model_rejected) never below
/// the Gauss-Newton sd at its point; for a not_converged estimate combined with the step to the
/// fitness's least-squares optimum, sqrt(sd^2 + step^2).
/// sd_source says so, sd_filter_si keeps the smoother's own sd and sd_gauss_newton_si the
/// Gauss-Newton one; not_observable is re-derived with the new sd (before the step);
/// at_box_edge, correlated:<other> and not_converged are unchanged (not_converged and
/// step_to_optimum_sd measure the distance to the least-squares optimum in its own sd).
/// Throws std::invalid_argument when the sizes differ, an sd is not finite and positive, or the
/// NIS is not a finite number >= 0 over >= 1 degree of freedom.
void use_filter_sd(UncertaintyReport& report, const FilterSd& filter);

/// The uncertainty blocks of a finished run's record, the same for `insid identify` results and
/// campaign run files: estimate_uncertainty at the optimizer's best point (the EKF-RTS reports
/// its own smoothed sd, use_filter_sd), then add_uncertainty_json. Returns the report.
UncertaintyReport add_run_uncertainty_json(nlohmann::json& out,
                                           const InsIdentificationProblem& problem,
                                           const opt::Optimizer& optimizer,
                                           const UncertaintyOptions& options,
                                           const NoiseReplicaSet* shared = nullptr);

/// The result layout's blocks added to a result JSON: "parameters", "correlation",
/// "uncertainty".
void add_uncertainty_json(nlohmann::json& out, const UncertaintyReport& report);

}  // namespace insid
