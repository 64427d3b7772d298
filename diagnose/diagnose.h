// The discrepancy workflow (`insid diagnose`, docs/design.md sec. 9; method and choices in
// diagnose/README.md):
//   1. fit the base model (optimizer, then a least-squares Levenberg-Marquardt polish);
//   2. noise model: M noise replicas of the same flight (data/noise_model.h) give draws of
//      the residuals' noise response; a low-rank + diagonal working covariance is built from
//      one part of them, the other part calibrates every statistic;
//   3. each candidate effect's sensitivity column by finite differences through the full
//      pipeline (alignment + mechanization + GNSS comparison), step one catalogue sigma;
//   4. generalised-least-squares estimate of each candidate after projecting out the model's
//      own columns; z = estimate / sd (sd from the calibration replicas), family-wise p-values
//      from the replicas' joint distribution (max |z| over the candidates);
//   5. name the most significant one, its collinear partners with the separating manoeuvre, and
//      the candidates this flight cannot observe;
//   6. add it, re-fit everything, repeat; gap before/after against the noise floor.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "identification/box_widening.h"
#include "identification/grade.h"
#include "identification/ins_problem.h"
#include "nav/fitness.h"

namespace insid::diagnose {

struct DiagnoseOptions {
  std::vector<EstimatedParameter> base;  ///< default: the grade's (nav: the paper's four)
  /// Sensor grade (identification/grade.h), settled by the caller (the CLI's --grade through
  /// settle_grade_and_window, or sensor_grade(name)); nullptr: auto, grade_for the dataset here.
  /// It sets the default base (nav: the paper's four; tactical, mems: also gyro_bias_z, each at
  /// the grade's sigma) and the unit (sigma) of every candidate: its sensitivity step,
  /// estimate_sigma, sd_sigma, min_detectable_sigma against observable_max_sigma, and the box
  /// of a found effect. nav is the catalogue's sigmas. (A base given with `base` keeps its own
  /// sigmas: the CLI gives every --base NAME without SIGMA the grade's,
  /// SensorGrade::parameter.)
  const SensorGrade* grade = nullptr;
  std::vector<std::string> candidates;  ///< empty: every catalogue effect not in the base
  int max_effects = 3;
  std::uint64_t seed = 1;
  AlignmentMode alignment = AlignmentMode::kPerCandidate;
  /// Windowed fitness (NavigationOptions::window_s, nav/fitness.h): 0 = one pure-INS run over
  /// the whole flight; W > 0 = the INS restarted from GNSS every W seconds (s).
  double window_s = 0.0;
  InitialAttitudeOptions initial_attitude;  ///< nav/alignment.h
  std::string algorithm = "dvpio";          ///< optimizer for the base fit ("none": LM only)
  int optimizer_iterations = 20;            ///< the optimizer's population is its preset's
  int replicas_basis = 40;                  ///< replicas building the working covariance
  int replicas_calibration = 80;            ///< replicas calibrating the statistics
  double alpha = 0.05;                      ///< family-wise false-alarm rate per iteration
  double collinear_threshold = 0.95;        ///< |correlation| of projected whitened columns
  /// Joint comparison after the fit: a significant runner-up whose likelihood-ratio difference
  /// to the named effect is below this many of its replica sd is reported as ambiguous with it.
  double ambiguity_z = 1.96;
  double observable_max_sigma = 30.0;  ///< minimum detectable size above this (catalogue
                                       ///< sigmas): not observable
  int monte_carlo_draws = 20000;       ///< draws for the family-wise max-|z| distribution
  /// Family-wise calibration of max |z| over the candidates:
  ///  "replica-max" (default): Westfall-Young, the data's |z| ranked among the calibration
  ///    replicas' own max |z| (each replica standardised leave-one-out, like the data);
  ///  "gaussian": a Gaussian with the replicas' correlation (assumes joint normality).
  std::string family_calibration = "replica-max";
  int threads = 0;        ///< OpenMP threads, 0 = default
  bool progress = false;  ///< human progress on stderr
  /// Noise levels to use instead of meta.json / the estimate (e.g. a user's spec sheet).
  std::optional<NoiseLevels> noise;
  /// The base fit's box: a base parameter pressing its box is widened as identify's
  /// (identification/box_widening.h, up to the grade's physical limit), and the wider fit kept
  /// when it lowers the base's least-squares misfit by more than `base_widening_min_gain`
  /// (relative): a clipped base makes every later name a stand-in for the clipped bias (on the
  /// real quadcopter's IMU2 a 41 % accelerometer scale factor), while a parameter the flight
  /// cannot observe only drifts to its edge and gains nothing. enabled = false: the box as given.
  BoxWideningOptions base_widening;
  double base_widening_min_gain = 1e-3;
  /// The gyro biases measured at rest over the static window (nav/gyro_at_rest.h), in the base
  /// and in every model after it, instead of fitted: gyro_bias_x|y|z leave the default base and
  /// the candidates (a base that names one is refused). What the flight sees beyond the motors-off
  /// bias (a motor offset) then shows as misfit, and a candidate can take it.
  bool gyro_bias_at_rest = false;
  /// The sd reported with the base's and the final model's sizes are scaled by the model misfit
  /// (identification/uncertainty.h, misfit_ratio) when the residual exceeds every replica's and
  /// this ratio: a real flight whose residual is 30x the noise floor does not know its sizes to
  /// the noise's precision. The naming statistics stay those of the noise replicas.
  double misfit_min_ratio = 4.0;

  /// "" when every field is usable, else a message naming the first bad field, its value and
  /// the allowed range (run_diagnose throws std::invalid_argument with it; nothing is clamped).
  std::string validate() const;
};

/// Residual time series kept for plots (GNSS epochs compared).
struct ResidualSeries {
  std::vector<double> t_s;
  std::vector<std::string> phase;
  std::vector<double> before;  ///< (dvE, dvN) interleaved, base fit
  std::vector<double> after;   ///< final model
};

struct DiagnoseResult {
  nlohmann::json report;  ///< the report.json contents
  ResidualSeries series;
  /// Names in `report["found"]` in order (convenience for tests).
  std::vector<std::string> found;
  std::vector<std::string> not_observable;
  double shrink = 0.0;
};

DiagnoseResult run_diagnose(std::shared_ptr<const Dataset> dataset, const DiagnoseOptions& options);

/// Family-wise calibration helpers (exposed for tests). `B` is q x M: the candidates'
/// estimators on M calibration replicas (any scale per row). Each replica's statistic is
/// standardised leave-one-out (by the RMS of the other M - 1 replicas, as the data's is by the
/// RMS of all M) and converted to a normal-equivalent |z| (Student t, dof = replicas used).
/// Returns each replica's max |z| over the q candidates, sorted ascending.
std::vector<double> replica_max_abs_z(const Eigen::MatrixXd& B);
/// Westfall-Young family-wise p-value of a normal-equivalent |z| against those maxima:
/// (1 + #{replica max >= |z|}) / (M + 1); exact under exchangeability of data and replicas.
double replica_max_p_family(const std::vector<double>& sorted_max, double z_abs);
/// The smallest |z| that the rule calls significant at `alpha` (p_family <= alpha): the
/// (k+1)-th largest replica max with k = floor(alpha (M + 1)) - 1; +inf when M is too small.
double replica_max_threshold(const std::vector<double>& sorted_max, double alpha);
/// The Gaussian rule: sorted draws of max |z| from N(0, R), R = the correlation of the rows of
/// `B` (assumes the standardised statistics are jointly normal).
std::vector<double> gaussian_max_abs_z(const Eigen::MatrixXd& B, int draws, std::uint64_t seed);

/// The residual series as CSV text: t_s,phase,dvE_before,dvN_before,dvE_after,dvN_after.
std::string series_csv_text(const ResidualSeries& series);

/// report.md text (tables; the figures come from scripts/diagnose_plots.py and are linked as
/// PREFIX_residuals.png, PREFIX_phases.png, PREFIX_scores.png when `figure_prefix` is not empty).
std::string report_markdown(const nlohmann::json& report, const std::string& figure_prefix);

}  // namespace insid::diagnose
