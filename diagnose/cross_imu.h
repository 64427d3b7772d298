// The cross-IMU check (`insid cross-imu`): several IMUs on one rigid airframe see the same
// rotation, so the difference of two IMUs' gyro readings, sample by sample, is the difference of
// their biases plus small scale-factor/misalignment differences times the rate plus noise. That
// is a truth for the *relative* gyro biases that needs no model of the flight; insid's own
// per-IMU estimates (insid-identify/2 results) are held against it.
//
// Model, per pair (a, b) and gyro axis i, at every sample k both IMUs logged:
//   y_i(k) = omega_a,i(k) - omega_b,i(k) = db_i + sum_j K_ij wbar_j(k) + e_i(k),
//   wbar(k) = (omega_a(k) + omega_b(k)) / 2,
// db the bias difference (a - b), K the scale/misalignment difference. The regressor is the
// pair's mean rate, not omega_b: IMU b's own noise sits in y with sign -1 and in omega_b with sign
// +1, which biases K by -var(n_b)/var(omega); with the mean it cancels for equal noise levels. A
// rate column whose sd over the window is below min_rate_sd_rad_s is noise rather than motion
// (on the ground: 0.1-0.2 deg/s); regressed on noise, K measures the ratio of the two IMUs' noise
// (K ~ 2 was seen on the shared copter log's ground window), so such a column is left out and db
// is the mean difference. Ordinary least squares; standard errors from the block (batch-means,
// cluster) sandwich V = (X'X)^-1 [sum_g s_g s_g'] (X'X)^-1 G/(G-1), s_g = sum_{k in block g} x_k
// e_k: vibration makes e strongly correlated from sample to sample, which the i.i.d. formula
// ignores (it is 0.6-0.7x the block value on the shared log). The block length is an option
// (default 2 s) and the SE at a ladder of block lengths is reported beside it.
//
// Accelerometers are not compared (see README "The cross-IMU check"): their difference holds the
// lever-arm terms dw/dt x r + w x (w x r) with r unknown, dw/dt from 50 Hz sampled rates is
// dominated by aliased vibration, and on a multicopter the z specific force stays near -g, so a z
// bias difference cannot be told from a z scale-factor difference.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "base/enum_table.h"
#include "data/dataset.h"

namespace insid::cross_imu {

/// One IMU's mean angular rates over its steps, on a clock shared by all the IMUs compared.
struct RateSeries {
  std::string name;                               ///< e.g. "IMU2" (the dataset's directory name)
  std::vector<double> t_s;                        ///< end of each step (the shared clock)
  std::vector<double> dt_s;                       ///< length of each step
  std::vector<Eigen::Vector3d> omega_ib_b_rad_s;  ///< dtheta / dt over the step, body FRD
  /// The part of each step the motors ran (the dataset's motor schedule); empty when unknown.
  std::vector<double> motor_on;
};

/// Rates from a dataset's increments, omega = dtheta / dt over each step (rows 1..n-1: the first
/// row's step has no row before it), with `t_offset_s` added to every time and the times scaled
/// by `t_scale` (clock = (t_s + t_offset_s) * t_scale: a dataset's boot clock). Throws
/// std::invalid_argument when the dataset has fewer than 3 IMU rows.
RateSeries rates_from_dataset(const Dataset& dataset, std::string name, double t_offset_s = 0.0,
                              double t_scale = 1.0);

struct CrossImuOptions {
  std::optional<double> t_start_s;  ///< first sample time used (the shared clock); none: all
  std::optional<double> t_end_s;    ///< last sample time used
  /// Block length of the standard errors (s). Default 2 s: on simulated flights with a
  /// 0.3 s-correlated gyro error the SE stops growing there (rms z 1.22 at 1 s, 1.15 at 2 s,
  /// 1.09 at 5 s over 48 pair-axes); on the shared copter log the SE plateaus from 0.5-1 s.
  /// A window with fewer than min_blocks such blocks uses window / min_blocks (recorded).
  double block_s = 2.0;
  /// Block lengths (s) at which the SE is also reported, to show how it depends on the length.
  std::vector<double> block_ladder_s = {0.02, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0};
  double segment_s = 10.0;  ///< the bias difference is also reported per segment of this length
  /// A rate column enters the regression only when its sd over the window reaches this
  /// (default 2 deg/s): below it the column is noise, not motion.
  double min_rate_sd_rad_s = 2.0 * 3.14159265358979323846 / 180.0;
  /// Two samples are the same instant when their times differ by at most this fraction of the
  /// first IMU's median step.
  double time_match_fraction = 0.01;
  /// Fewest blocks an SE is computed from (fewer: the SE is not reported).
  int min_blocks = 10;
  /// "" when valid, else the reason naming the option and the bad value.
  std::string validate() const;
};

/// One gyro axis of one pair.
struct AxisDifference {
  double bias_diff_rad_s = 0.0;    ///< db_i = bias_a - bias_b
  std::optional<double> se_rad_s;  ///< block SE at CrossImuOptions::block_s (none: too few blocks)
  double se_iid_rad_s = 0.0;       ///< the i.i.d. OLS SE (for comparison only)
  /// K_i,j (dimensionless) for the rate columns used; nullopt for a column left out.
  std::array<std::optional<double>, 3> rate_coeff;
  std::array<std::optional<double>, 3> rate_coeff_se;
  double residual_sd_rad_s = 0.0;
  /// (block length s, SE rad/s) over the ladder; SE nullopt where fewer than min_blocks blocks.
  std::vector<std::pair<double, std::optional<double>>> se_by_block;
  /// The step of the difference at motor start, when the window holds 5 blocks (as a segment's
  /// SE needs) with the motors off and as many with them on: y = db_off + jump u + K wbar + e, u
  /// the motor state (the pair's motor offset difference, gyro_motor_offset_a -
  /// gyro_motor_offset_b), block SE.
  std::optional<double> motor_jump_rad_s, motor_jump_se_rad_s;
  /// db_off of that regression: the bias difference with the motors off (what a result that
  /// estimates motor offsets calls the bias difference), with its block SE.
  std::optional<double> motors_off_bias_diff_rad_s, motors_off_se_rad_s;
};

/// The bias difference over one segment of the window: mean of y - K wbar (K from the whole
/// window), SE from the blocks of block_s inside the segment.
struct Segment {
  double t_start_s = 0.0, t_end_s = 0.0;
  std::size_t samples = 0;
  Eigen::Vector3d bias_diff_rad_s = Eigen::Vector3d::Zero();
  std::array<std::optional<double>, 3> se_rad_s;
};

struct PairDifference {
  std::size_t a = 0, b = 0;  ///< indices into the series: the difference is a - b
  std::string name_a, name_b;
  bool against_first = false;  ///< b is the first IMU (the independent pairs)
  std::size_t samples = 0;     ///< matched samples in the window
  std::size_t unmatched = 0;   ///< samples of a or b in the window without a partner
  Eigen::Vector3d wbar_sd_rad_s = Eigen::Vector3d::Zero();  ///< sd of the regressors
  std::array<bool, 3> rate_column_used{};
  std::size_t motor_off_samples = 0, motor_on_samples = 0;  ///< u < 0.5, u >= 0.5 (both known)
  std::array<AxisDifference, 3> axes;
  std::vector<Segment> segments;
};

struct CrossImuReport {
  std::vector<std::string> names;
  double t_start_s = 0.0, t_end_s = 0.0;  ///< the window actually used
  double median_step_s = 0.0;
  double block_s_used = 0.0;  ///< options.block_s, or window / min_blocks when shorter
  CrossImuOptions options;
  std::vector<PairDifference> pairs;  ///< every pair a > b (b = 0 first: against the first IMU)
};

/// The direct differences of every pair (j - i for i < j). Throws std::invalid_argument (bad
/// options, fewer than two series, a series without samples in the window, no matched samples,
/// too few samples for a regression) with a message that names what is wrong.
CrossImuReport direct_differences(const std::vector<RateSeries>& series,
                                  const CrossImuOptions& options);

/// One gyro bias estimate of an insid-identify/2 result (SI, rad/s).
struct EstimatedBias {
  double estimate_rad_s = 0.0;
  std::optional<double> sd_rad_s;  ///< nullopt where the result gives no number
  std::vector<std::string> flags;  ///< at_box_edge, not_converged, ...
};

/// The gyro biases an insid-identify/2 result estimated, by axis (absent: not estimated).
struct ResultEstimates {
  std::string source;  ///< the file
  std::string algorithm;
  std::array<std::optional<EstimatedBias>, 3> gyro_bias;
  std::array<std::optional<EstimatedBias>, 3> gyro_motor_offset;
  /// The result measured its gyro biases at rest (identify --gyro-bias-at-rest) rather than
  /// estimating them from the flight.
  bool gyro_bias_at_rest = false;
};

/// Reads `path` (an insid-identify/2 result). Throws std::runtime_error naming the file and the
/// field when it is not one.
ResultEstimates read_identify_result(const std::filesystem::path& path);

enum class Verdict { kAgree, kCheck, kDisagree, kNotCompared };
inline constexpr EnumTable<Verdict, 4> kVerdictNames{"verdict",
                                                     {{{Verdict::kAgree, "agree"},
                                                       {Verdict::kCheck, "check"},
                                                       {Verdict::kDisagree, "disagree"},
                                                       {Verdict::kNotCompared, "not_compared"}}}};
inline const char* to_string(Verdict v) { return kVerdictNames.name(v).data(); }

/// Verdict from |z|: agree <= 2, check <= 3, disagree beyond.
Verdict verdict_from_z(double z);

/// insid's estimated difference against the direct one, for one pair and axis.
struct ComparisonRow {
  std::size_t pair = 0;  ///< index into CrossImuReport::pairs
  int axis = 0;          ///< 0 x, 1 y, 2 z
  /// The quantity compared: the bias difference (gyro_bias), or the motor offset difference
  /// against the direct jump at motor start (gyro_motor_offset; rows only where the window has a
  /// jump and a result estimates the offset).
  EffectKind kind = EffectKind::kBias;
  std::optional<double> insid_diff_rad_s, insid_sd_rad_s;
  double direct_rad_s = 0.0;
  std::optional<double> direct_se_rad_s;
  std::optional<double> z;  ///< (insid - direct) / sqrt(sd_a^2 + sd_b^2 + se^2)
  Verdict verdict = Verdict::kNotCompared;
  std::string reason;              ///< why not compared, when so
  std::vector<std::string> flags;  ///< e.g. "IMU2 at_box_edge"
};

/// Compares the results (one per series, same order) with the direct differences. Throws
/// std::invalid_argument when the counts differ.
std::vector<ComparisonRow> compare_with_results(const CrossImuReport& report,
                                                const std::vector<ResultEstimates>& results);

/// The plain warnings for the rows that disagree (|z| > 3) or rest on an estimate at its box
/// edge, one line each.
std::vector<std::string> comparison_warnings(const CrossImuReport& report,
                                             const std::vector<ComparisonRow>& rows);

/// The report (and rows when given) as JSON: every number in rad/s and deg/s.
nlohmann::json report_json(const CrossImuReport& report, const std::vector<ComparisonRow>* rows);

/// The tables printed on stderr (and in results/*.md): differences per pair-axis, per segment,
/// and the comparison when rows are given.
std::string report_text(const CrossImuReport& report, const std::vector<ComparisonRow>* rows);

/// The same as a markdown table (pair-axis differences, SE, and the comparison when given).
std::string report_markdown(const CrossImuReport& report, const std::vector<ComparisonRow>* rows);

}  // namespace insid::cross_imu
