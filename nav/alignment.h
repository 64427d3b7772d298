// Static coarse alignment: levelling from the mean specific force and gyrocompassing from the
// mean angular rate (analytic / TRIAD form, e.g. Groves 2013 sec. 5.6). Re-aligning for a
// different candidate error costs O(1): the window sums are taken once from the measured data
// and the (affine) error model is inverted on the window means.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "data/dataset.h"
#include "model/rotation.h"
#include "model/sensor_errors.h"

namespace insid {

/// Sums over the alignment window of measured increments (computed once per dataset).
struct AlignmentWindow {
  Eigen::Vector3d sum_dtheta_b = Eigen::Vector3d::Zero();  ///< (rad)
  Eigen::Vector3d sum_dv_b = Eigen::Vector3d::Zero();      ///< (m/s)
  double sum_dt_s = 0.0;
  double mean_t_mid_s = 0.0;   ///< dt-weighted mean of the samples' mid-times (for bias drifts)
  double mean_motor_on = 0.0;  ///< part of the window the motors ran (for the motor offsets)
  std::size_t count = 0;

  /// Window over imu[begin, end); the first sample's interval starts at t_start_s. `motors`:
  /// when the motors ran (DatasetMeta::motors).
  static AlignmentWindow from_imu(const std::vector<ImuSample>& imu, std::size_t begin,
                                  std::size_t end, double t_start_s,
                                  const MotorSchedule& motors = {});
};

/// C_b_n from mean specific force f_ib_b (m/s^2) and mean angular rate omega_ib_b (rad/s) of a
/// stationary IMU. Throws std::invalid_argument when the vectors are (nearly) parallel or zero.
Eigen::Matrix3d coarse_align(const Eigen::Vector3d& f_ib_b, const Eigen::Vector3d& omega_ib_b);

/// C_b_n for a candidate error model, in O(1) from the precomputed window sums.
Eigen::Matrix3d align_window(const AlignmentWindow& window, const ImuCompensator& compensator);

// ---------------------------------------------------------------------------------------------
// Initial-attitude modes. README.md, "Initial attitude", says what each assumes.
//   gyrocompass    levelling + gyrocompassing on the static window (the paper; nav grade);
//   level+heading  levelling on the static window, heading given (--heading-deg), from the
//                  GNSS course once the speed exceeds a threshold, carried back to the start,
//                  or measured (heading.csv: dual antenna / magnetometer; --heading-source);
//   given          roll/pitch/yaw of meta.json `initial` (the data's own attitude);
//   truth          truth.csv at the navigation start, else meta.json `initial` (simulations).
// gyrocompass and level+heading depend on the candidate (levelling on the compensated window,
// O(1) per candidate); given and truth are the same for every candidate.

enum class InitialAttitudeMode { kGyrocompass, kLevelHeading, kGiven, kTruth };
std::string to_string(InitialAttitudeMode mode);
/// "gyrocompass" (or its older name "align", still read) | "level+heading" | "given" | "truth";
/// throws std::invalid_argument naming the value otherwise.
InitialAttitudeMode initial_attitude_mode_from_string(const std::string& text);

/// Where level+heading takes its heading (--heading-source).
enum class HeadingSource { kCourse, kGiven, kMeasured };
std::string to_string(HeadingSource source);
/// "course" | "given" | "measured"; throws std::invalid_argument naming the value otherwise.
HeadingSource heading_source_from_string(const std::string& text);

struct InitialAttitudeOptions {
  InitialAttitudeMode mode = InitialAttitudeMode::kGyrocompass;
  /// level+heading: where the heading comes from; unset: given when heading_deg is set, else
  /// the course (the behaviour before --heading-source). kMeasured: heading.csv, the circular
  /// mean of its samples in the static window, or where it has none there, of the samples
  /// within course_span_s after the first one after the navigation start, carried back.
  std::optional<HeadingSource> heading_source;
  /// level+heading: the heading at the navigation start (deg, clockwise from north); when
  /// absent, the GNSS course carried back to the start.
  std::optional<double> heading_deg;
  /// level+heading from the course: GNSS epochs count once their horizontal speed reaches this
  /// (m/s); the course's sd is about gnss_vel_sigma / speed (0.03 m/s at 1 m/s: 1.7 deg).
  double course_min_speed_mps = 1.0;
  /// ... and the course is the circular mean, carried back to the start, of the fast epochs
  /// within this span after the first one (s; 0 = the first fast epoch only).
  double course_span_s = 2.0;
  /// A static window whose GNSS horizontal speed exceeds this (m/s) is not static: refused.
  double static_max_speed_mps = 0.5;
  /// Feasibility of gyrocompassing: refused when the expected heading sd exceeds this (deg).
  /// 1 deg is about what level+heading gets from a GNSS course at walking speed and above.
  double gyrocompass_max_heading_sd_deg = 1.0;
  /// The gyro bias the gyrocompass may meet (rad/s): the estimated gyro biases' search box
  /// (identify), else the catalogue sigma (navigate: the data are taken as compensated).
  double gyro_bias_allowance_rad_s = kSigmaGyroRadS;

  /// "" when valid, else the reason naming the bad value.
  std::string validate() const;
  /// level+heading: the source in effect (heading_source, else given / course).
  HeadingSource effective_heading_source() const {
    return heading_source ? *heading_source
                          : (heading_deg ? HeadingSource::kGiven : HeadingSource::kCourse);
  }
  /// Short description for results and cache keys, e.g. "level+heading (course >= 1 m/s, 2 s)".
  std::string describe() const;
};

/// Expected heading sd of gyrocompassing on a window of length T. The heading error is the
/// east gyro error over the horizontal Earth rate, dpsi = eps_E / (W cos lat) (the analytic
/// coarse alignment's error, Groves 2013 sec. 5.6.2; nav/alignment_test.cc checks it), with
/// eps_E from the angle random walk averaged over the window (N / sqrt(T)) and the allowed
/// bias b: sd = sqrt(N^2 / T + b^2) / (W cos lat).
struct GyrocompassFeasibility {
  double heading_sd_rad = 0.0;
  double arw_rad_rts = 0.0;   ///< angle random walk used (rad/sqrt(s))
  bool arw_declared = false;  ///< from meta.json noise.arw_deg_rth (else estimated)
  double window_s = 0.0;
  double bias_allowance_rad_s = 0.0;
  double horizontal_earth_rate_rad_s = 0.0;  ///< W cos lat
  /// "expected gyrocompass heading sd 57.3 deg (angle random walk 0.2 deg/sqrt(h) declared
  /// in meta.json, 30 s window, gyro bias allowance 0.01 deg/h, Earth rate 11.5 deg/h east)".
  std::string describe() const;
};
GyrocompassFeasibility gyrocompass_feasibility(double arw_rad_rts, bool arw_declared,
                                               double window_s, double bias_allowance_rad_s,
                                               double omega_ie_rad_s, double lat_rad);

/// Angle random walk (rad/sqrt(s)) estimated from the rate scatter on imu[begin, end): the
/// robust (MAD) spread of first differences of the per-sample rates, per axis, averaged in
/// variance over the three axes; N = sigma_rate * sqrt(dt). Vibration counts as noise (an
/// overestimate, which refuses gyrocompassing sooner). 0 with fewer than 3 samples.
double estimate_arw_rad_rts(const std::vector<ImuSample>& imu, std::size_t begin, std::size_t end,
                            double t_start_s);

/// Velocity random walk (m/s/sqrt(s)) estimated the same way from the specific-force increments.
double estimate_vrw_mps_rts(const std::vector<ImuSample>& imu, std::size_t begin, std::size_t end,
                            double t_start_s);

/// C_b_n from the up direction of a mean specific force f_ib_b and a heading (yaw, clockwise
/// from north): roll and pitch from the levelling, yaw given.
Eigen::Matrix3d level_with_yaw(const Eigen::Vector3d& f_ib_b, double yaw_rad);

/// Mean specific force f_ib_b [m/s^2] of the IMU rows whose time is <= t_end_s (the sum of their
/// velocity increments over the sum of their intervals, from the second row on): the levelling
/// of a static window for a magnetometer's tilt compensation. nullopt when fewer than two rows
/// fall in the window.
std::optional<Eigen::Vector3d> mean_specific_force_b(const std::vector<ImuSample>& imu,
                                                     double t_end_s);

/// True heading (rad, clockwise from true north) of the body x axis from a magnetometer
/// reading mag_b (body FRD, any unit) and the specific force f_ib_b of a static IMU (tilt
/// compensation): the field is levelled with the roll and pitch of level_with_yaw(f_ib_b, 0)
/// (C_b_n with yaw 0, Groves 2013 sec. 6.1.1), its azimuth in that frame is alpha = atan2(m_E,
/// m_N) = declination - yaw, so yaw = declination - alpha (declination east of true north +).
/// Throws std::invalid_argument when the field is (nearly) vertical or zero.
double magnetometer_true_heading_rad(const Eigen::Vector3d& mag_b, const Eigen::Vector3d& f_ib_b,
                                     double declination_rad);

/// Sums that carry a heading measured later back to the navigation start (level+heading from
/// the GNSS course), with the candidate's gyro compensation applied in O(1). The Euler yaw
/// changes at psi_dot = d + sin(theta) phi_dot (ZYX kinematics), d the rotation rate of the
/// body about the local down axis: d = -u_b . omega_ib_b + W sin(lat) (+ the transport rate's
/// vertical part, v_E tan(lat) / R, below 1e-6 rad/s on the ground and left out), u_b the
/// local up in body axes. u_b and the roll/pitch term come from a reference attitude track (the
/// data as recorded, from the levelled start); the candidate enters through the compensated
/// increments: sum u_b^T G^-1 (dtheta - (b0 + b_dot t_mid) dt), linear in the sums below.
struct YawCarry {
  Eigen::Matrix3d sum_u_dtheta = Eigen::Matrix3d::Zero();    ///< sum u_b dtheta_b^T (rad)
  Eigen::Vector3d sum_u_dt = Eigen::Vector3d::Zero();        ///< sum u_b dt (s)
  Eigen::Vector3d sum_u_tmid_dt = Eigen::Vector3d::Zero();   ///< sum u_b t_mid dt (s^2)
  Eigen::Vector3d sum_u_motor_dt = Eigen::Vector3d::Zero();  ///< sum u_b m dt (s), m motor part
  double span_s = 0.0;                                       ///< time from the navigation start
  double roll_pitch_term_rad = 0.0;  ///< sum sin(theta) dphi on the reference track
};
/// Yaw change (rad, clockwise +) from the navigation start over the carry's span.
double yaw_change_rad(const YawCarry& carry, const ImuCompensator& compensator,
                      double earth_up_rate_rad_s);

/// The measured heading level+heading used (--heading-source measured): the circular mean of
/// heading.csv samples, its sd, and where they were taken.
struct MeasuredHeading {
  HeadingSourceKind kind = HeadingSourceKind::kDualAntenna;
  std::optional<double> declination_deg;  ///< magnetometer: as meta.json records it
  bool carried = false;   ///< samples after the navigation start, carried back (course_fixes())
  std::size_t count = 0;  ///< samples averaged
  std::size_t first_line = 0;  ///< heading.csv line of the first sample used
  double t_first_s = 0.0, t_last_s = 0.0;
  double mean_rad = 0.0;  ///< circular mean of the samples (before any carry)
  /// Circular sd of the samples, sqrt(-2 ln R) (R the mean resultant length).
  double scatter_rad = 0.0;
  std::optional<double> sample_sd_rad;  ///< rms of the samples' own sd (heading.csv sd_deg)
  /// sd of the mean: max(sample sd, scatter) / sqrt(count), the samples taken as independent (a
  /// slowly varying error, multipath or a magnetometer's hard iron, is not averaged out and is
  /// not in it).
  double sd_rad = 0.0;
};

/// One GNSS epoch whose course sets the heading (level+heading without --heading-deg).
struct CourseFix {
  std::size_t gnss_index = 0;
  double t_s = 0.0;
  double course_rad = 0.0;  ///< atan2(vE, vN), clockwise from north
  double speed_mps = 0.0;
  YawCarry carry;  ///< from the navigation start to t_s
  /// d(yaw change)/d(roll, pitch at the start) on the reference track (finite differences):
  /// the carry is linearised about the track levelled from the data as recorded, and a
  /// candidate whose levelling differs (a compensated 20 mg accelerometer bias tilts it by
  /// 1.2 deg) moves the roll/pitch term of a turn to first order.
  double dyaw_droll0 = 0.0, dyaw_dpitch0 = 0.0;
};

/// The attitude at the navigation start, per mode, for any candidate. Built once per dataset
/// (it checks the mode against the data and throws std::invalid_argument with what to give
/// instead); attitude() is O(1) per candidate (O(fast epochs) for the course).
class InitialAttitude {
 public:
  InitialAttitude() = default;
  /// `window` over imu[window_begin, window_end) (count 0: none); the navigation starts at
  /// imu[nav_begin - 1].t_s. Gyrocompass and level+heading need a static window; gyrocompass
  /// must also pass the feasibility check.
  InitialAttitude(const Dataset& dataset, const InitialAttitudeOptions& options,
                  const AlignmentWindow& window, std::size_t window_begin, std::size_t window_end,
                  double window_start_t_s, std::size_t nav_begin);

  const InitialAttitudeOptions& options() const { return options_; }
  bool depends_on_candidate() const {
    return options_.mode == InitialAttitudeMode::kGyrocompass ||
           options_.mode == InitialAttitudeMode::kLevelHeading;
  }
  /// C_b_n at the navigation start for a candidate's compensation.
  Eigen::Matrix3d attitude(const ImuCompensator& compensator) const;
  /// Heading at the navigation start (rad) for level+heading; the given one or the course's.
  double level_heading_yaw_rad(const ImuCompensator& compensator) const;

  /// Yaw change (rad, clockwise +) from the navigation start to a course epoch for a candidate:
  /// its compensated gyros on the reference track, plus the track's sensitivity to the start
  /// tilt times the candidate's levelling minus the track's. O(1).
  double yaw_change_to(const CourseFix& fix, const ImuCompensator& compensator) const;
  /// Course epochs used (level+heading without --heading-deg), in time order; with a measured
  /// heading carried back, its samples (course_rad the measured heading, speed_mps 0,
  /// gnss_index the heading.csv row).
  const std::vector<CourseFix>& course_fixes() const { return fixes_; }
  /// --heading-source measured: the samples used and their mean and sd.
  const std::optional<MeasuredHeading>& measured_heading() const { return measured_; }
  /// Gyrocompass only: the feasibility figures (heading sd and what went into it).
  const std::optional<GyrocompassFeasibility>& feasibility() const { return feasibility_; }

 private:
  InitialAttitudeOptions options_;
  AlignmentWindow window_;
  Eigen::Matrix3d C_b_n_fixed_ = Eigen::Matrix3d::Identity();        // given / truth
  EulerAngles tilt_offset(const ImuCompensator& compensator) const;  // candidate - track start
  double yaw_change_to(const CourseFix& fix, const ImuCompensator& compensator,
                       const EulerAngles& tilt_offset) const;
  double earth_up_rate_rad_s_ = 0.0;
  EulerAngles reference_tilt_;  // roll/pitch where the reference track starts
  std::vector<CourseFix> fixes_;
  std::optional<MeasuredHeading> measured_;
  std::optional<GyrocompassFeasibility> feasibility_;
};

/// Truth attitude at time t: the nearest truth.csv row, else meta.json `initial` (valid while
/// the data are static). Throws naming what is missing.
Eigen::Matrix3d truth_attitude_at(const Dataset& dataset, double t_s);

}  // namespace insid
