#include "nav/alignment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <Eigen/Geometry>

#include "base/enum_table.h"
#include "base/number_text.h"
#include "data/gnss_interpolation.h"
#include "model/rotation.h"

namespace insid {

AlignmentWindow AlignmentWindow::from_imu(const std::vector<ImuSample>& imu, std::size_t begin,
                                          std::size_t end, double t_start_s,
                                          const MotorSchedule& motors) {
  if (begin >= end || end > imu.size())
    throw std::invalid_argument("alignment window is empty or out of range");
  AlignmentWindow w;
  double sum_t_mid_dt = 0.0, sum_motor_dt = 0.0;
  double t_prev = t_start_s;
  for (std::size_t k = begin; k < end; ++k) {
    const double dt = imu[k].t_s - t_prev;
    w.sum_dtheta_b += imu[k].dtheta_b_rad;
    w.sum_dv_b += imu[k].dv_b_mps;
    w.sum_dt_s += dt;
    sum_t_mid_dt += (imu[k].t_s - 0.5 * dt) * dt;
    if (!motors.empty()) sum_motor_dt += motors.fraction(t_prev, imu[k].t_s) * dt;
    t_prev = imu[k].t_s;
  }
  w.count = end - begin;
  w.mean_t_mid_s = sum_t_mid_dt / w.sum_dt_s;
  w.mean_motor_on = sum_motor_dt / w.sum_dt_s;
  return w;
}

Eigen::Matrix3d coarse_align(const Eigen::Vector3d& f_ib_b, const Eigen::Vector3d& omega_ib_b) {
  // A static IMU senses f_n = (0, 0, g) (up) and omega_ie_n = (0, W cos lat, W sin lat).
  // In n: omega x f is east, f is up, up x east is north. The same constructions in b give the
  // n axes expressed in b, i.e. the columns of C_n_b = C_b_n^T (analytic coarse alignment).
  const double f_norm = f_ib_b.norm();
  if (!(f_norm > 0.0)) throw std::invalid_argument("coarse alignment: zero specific force");
  const Eigen::Vector3d up_b = f_ib_b / f_norm;
  const Eigen::Vector3d east_raw_b = omega_ib_b.cross(up_b);
  const double east_norm = east_raw_b.norm();
  if (!(east_norm > 1e-3 * omega_ib_b.norm()) || !(east_norm > 0.0))
    throw std::invalid_argument(
        "coarse alignment: angular rate parallel to specific force (at a pole?)");
  const Eigen::Vector3d east_b = east_raw_b / east_norm;
  const Eigen::Vector3d north_b = up_b.cross(east_b);
  Eigen::Matrix3d C_b_n;
  C_b_n.row(0) = east_b.transpose();
  C_b_n.row(1) = north_b.transpose();
  C_b_n.row(2) = up_b.transpose();
  return C_b_n;
}

Eigen::Matrix3d align_window(const AlignmentWindow& window, const ImuCompensator& compensator) {
  Eigen::Vector3d omega_ib_b = window.sum_dtheta_b / window.sum_dt_s;
  Eigen::Vector3d f_ib_b = window.sum_dv_b / window.sum_dt_s;
  compensator.compensate_mean(window.mean_t_mid_s, omega_ib_b, f_ib_b, window.mean_motor_on);
  return coarse_align(f_ib_b, omega_ib_b);
}

// ---------------------------------------------------------------------------------------------
// Initial-attitude modes.

namespace {

constexpr double kRadSToDegH = kRadToDeg * 3600.0;
constexpr double kRadRtsToDegRth = kRadToDeg * 60.0;  // sqrt(h) = 60 sqrt(s)

}  // namespace

// "align": the older name of gyrocompass, still read.
constexpr EnumTable<InitialAttitudeMode, 5> kInitialAttitudeModeNames{
    "--initial-attitude",
    {{{InitialAttitudeMode::kGyrocompass, "gyrocompass"},
      {InitialAttitudeMode::kGyrocompass, "align"},
      {InitialAttitudeMode::kLevelHeading, "level+heading"},
      {InitialAttitudeMode::kGiven, "given"},
      {InitialAttitudeMode::kTruth, "truth"}}}};

constexpr EnumTable<HeadingSource, 3> kHeadingSourceNames{
    "--heading-source",
    {{{HeadingSource::kCourse, "course"},
      {HeadingSource::kGiven, "given"},
      {HeadingSource::kMeasured, "measured"}}}};

std::string to_string(InitialAttitudeMode mode) {
  return std::string(kInitialAttitudeModeNames.name(mode));
}

InitialAttitudeMode initial_attitude_mode_from_string(const std::string& text) {
  return kInitialAttitudeModeNames.value(text);
}

std::string to_string(HeadingSource source) {
  return std::string(kHeadingSourceNames.name(source));
}

HeadingSource heading_source_from_string(const std::string& text) {
  return kHeadingSourceNames.value(text);
}

std::string InitialAttitudeOptions::validate() const {
  if (heading_deg && !std::isfinite(*heading_deg))
    return "heading_deg must be finite, got " + number_text(*heading_deg, 3);
  if (heading_deg && mode != InitialAttitudeMode::kLevelHeading)
    return "a heading (--heading-deg " + number_text(*heading_deg, 10) +
           ") is only used by --initial-attitude level+heading, not " + to_string(mode);
  if (heading_source && mode != InitialAttitudeMode::kLevelHeading)
    return "a heading source (--heading-source " + to_string(*heading_source) +
           ") is only used by --initial-attitude level+heading, not " + to_string(mode);
  if (heading_source == HeadingSource::kGiven && !heading_deg)
    return "--heading-source given needs the heading: --heading-deg H";
  if (heading_source && *heading_source != HeadingSource::kGiven && heading_deg)
    return "--heading-deg " + number_text(*heading_deg, 10) +
           " gives the heading, but --heading-source " + to_string(*heading_source) +
           " takes it from elsewhere; give one of them";
  if (!(course_min_speed_mps > 0.0) || !std::isfinite(course_min_speed_mps))
    return "course_min_speed_mps must be a finite number > 0, got " +
           number_text(course_min_speed_mps, 3);
  if (!(course_span_s >= 0.0) || !std::isfinite(course_span_s))
    return "course_span_s must be a finite number >= 0, got " + number_text(course_span_s, 3);
  if (!(static_max_speed_mps > 0.0) || !std::isfinite(static_max_speed_mps))
    return "static_max_speed_mps must be a finite number > 0, got " +
           number_text(static_max_speed_mps, 3);
  if (!(gyrocompass_max_heading_sd_deg > 0.0))
    return "gyrocompass_max_heading_sd_deg must be > 0, got " +
           number_text(gyrocompass_max_heading_sd_deg, 3);
  if (!(gyro_bias_allowance_rad_s >= 0.0) || !std::isfinite(gyro_bias_allowance_rad_s))
    return "gyro_bias_allowance_rad_s must be a finite number >= 0, got " +
           number_text(gyro_bias_allowance_rad_s, 3);
  return "";
}

std::string InitialAttitudeOptions::describe() const {
  if (mode != InitialAttitudeMode::kLevelHeading) return to_string(mode);
  if (heading_deg) return "level+heading (heading " + number_text(*heading_deg, 10) + " deg given)";
  if (effective_heading_source() == HeadingSource::kMeasured)
    return "level+heading (measured heading: heading.csv in the static window, else over " +
           number_text(course_span_s, 10) + " s after the navigation start)";
  return "level+heading (GNSS course >= " + number_text(course_min_speed_mps, 10) + " m/s over " +
         number_text(course_span_s, 10) + " s)";
}

std::string GyrocompassFeasibility::describe() const {
  return "expected gyrocompass heading sd " + number_text(heading_sd_rad * kRadToDeg, 3) +
         " deg (angle random walk " + number_text(arw_rad_rts * kRadRtsToDegRth, 3) +
         " deg/sqrt(h) " +
         (arw_declared ? "declared in meta.json noise.arw_deg_rth"
                       : "estimated from the static window's rate scatter") +
         ", averaged over the " + number_text(window_s, 3) +
         " s static window; gyro bias allowance " +
         number_text(bias_allowance_rad_s * kRadSToDegH, 3) + " deg/h; horizontal Earth rate " +
         number_text(horizontal_earth_rate_rad_s * kRadSToDegH, 3) + " deg/h)";
}

GyrocompassFeasibility gyrocompass_feasibility(double arw_rad_rts, bool arw_declared,
                                               double window_s, double bias_allowance_rad_s,
                                               double omega_ie_rad_s, double lat_rad) {
  GyrocompassFeasibility f;
  f.arw_rad_rts = arw_rad_rts;
  f.arw_declared = arw_declared;
  f.window_s = window_s;
  f.bias_allowance_rad_s = bias_allowance_rad_s;
  f.horizontal_earth_rate_rad_s = omega_ie_rad_s * std::abs(std::cos(lat_rad));
  // dpsi = eps_E / (W cos lat); eps_E: ARW averaged over T (N / sqrt(T)) and the bias allowance.
  const double eps_E =
      std::sqrt(arw_rad_rts * arw_rad_rts / window_s + bias_allowance_rad_s * bias_allowance_rad_s);
  f.heading_sd_rad = eps_E / f.horizontal_earth_rate_rad_s;
  return f;
}

namespace {

// White-noise density (unit/sqrt(s)) of the increments `member` (dtheta or dv) on
// imu[begin, end): see estimate_arw_rad_rts.
double estimate_white_noise_density(const std::vector<ImuSample>& imu, std::size_t begin,
                                    std::size_t end, double t_start_s,
                                    Eigen::Vector3d ImuSample::*member) {
  if (end > imu.size() || end < begin + 3) return 0.0;
  // First differences of per-sample rates: 2 sigma^2 for white rate noise, bias removed.
  std::vector<double> diffs[3];
  double t_prev = t_start_s, sum_dt = 0.0;
  Eigen::Vector3d rate_prev = Eigen::Vector3d::Zero();
  for (std::size_t k = begin; k < end; ++k) {
    const double dt = imu[k].t_s - t_prev;
    t_prev = imu[k].t_s;
    if (!(dt > 0.0)) continue;
    const Eigen::Vector3d rate = imu[k].*member / dt;
    if (k > begin)
      for (int i = 0; i < 3; ++i) diffs[i].push_back(rate[i] - rate_prev[i]);
    rate_prev = rate;
    sum_dt += dt;
  }
  if (diffs[0].size() < 2 || !(sum_dt > 0.0)) return 0.0;
  const double dt_mean = sum_dt / static_cast<double>(end - begin);
  double var_sum = 0.0;
  for (auto& d : diffs) {
    for (double& v : d) v = std::abs(v);
    auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
    std::nth_element(d.begin(), mid, d.end());
    const double sigma_diff = 1.4826 * *mid;  // MAD -> sd of a Gaussian (median 0)
    var_sum += sigma_diff * sigma_diff / 2.0;
  }
  // Rate noise sd on one sample of length dt is N / sqrt(dt).
  return std::sqrt(var_sum / 3.0) * std::sqrt(dt_mean);
}

}  // namespace

double estimate_arw_rad_rts(const std::vector<ImuSample>& imu, std::size_t begin, std::size_t end,
                            double t_start_s) {
  return estimate_white_noise_density(imu, begin, end, t_start_s, &ImuSample::dtheta_b_rad);
}

double estimate_vrw_mps_rts(const std::vector<ImuSample>& imu, std::size_t begin, std::size_t end,
                            double t_start_s) {
  return estimate_white_noise_density(imu, begin, end, t_start_s, &ImuSample::dv_b_mps);
}

Eigen::Matrix3d level_with_yaw(const Eigen::Vector3d& f_ib_b, double yaw_rad) {
  const double f_norm = f_ib_b.norm();
  if (!(f_norm > 0.0) || !std::isfinite(f_norm))
    throw std::invalid_argument("levelling: zero or non-finite specific force");
  // Static, f_ib_n = (0, 0, g) (up): up_b = f / |f| is C_b_n's third row, which for FRD -> ENU
  // with roll phi and pitch theta is (sin theta, -sin phi cos theta, -cos phi cos theta).
  const Eigen::Vector3d up_b = f_ib_b / f_norm;
  EulerAngles e;
  e.pitch_rad = std::asin(std::clamp(up_b.x(), -1.0, 1.0));
  e.roll_rad = std::atan2(-up_b.y(), -up_b.z());
  e.yaw_rad = yaw_rad;
  return C_b_n_from_euler(e);
}

std::optional<Eigen::Vector3d> mean_specific_force_b(const std::vector<ImuSample>& imu,
                                                     double t_end_s) {
  Eigen::Vector3d dv_b_mps = Eigen::Vector3d::Zero();
  double dt_s = 0.0;
  for (std::size_t k = 1; k < imu.size() && imu[k].t_s <= t_end_s + 1e-9; ++k) {
    dv_b_mps += imu[k].dv_b_mps;
    dt_s += imu[k].t_s - imu[k - 1].t_s;
  }
  if (!(dt_s > 0.0)) return std::nullopt;
  return Eigen::Vector3d(dv_b_mps / dt_s);
}

double magnetometer_true_heading_rad(const Eigen::Vector3d& mag_b, const Eigen::Vector3d& f_ib_b,
                                     double declination_rad) {
  const Eigen::Vector3d m_level = level_with_yaw(f_ib_b, 0.0) * mag_b;  // (E, N, U), yaw 0
  const double horizontal = std::hypot(m_level.x(), m_level.y());
  if (!(horizontal > 1e-3 * mag_b.norm()) || !std::isfinite(horizontal))
    throw std::invalid_argument(
        "magnetometer heading: the field is vertical or zero in the levelled frame (a magnetic "
        "pole, or no field)");
  return wrap_pi(declination_rad - std::atan2(m_level.x(), m_level.y()));
}

double yaw_change_rad(const YawCarry& carry, const ImuCompensator& compensator,
                      double earth_up_rate_rad_s) {
  // psi_dot = d + sin(theta) phi_dot, d = -u_b . omega_ib_b + W sin(lat).
  return -compensator.projected_gyro_sum(carry.sum_u_dtheta, carry.sum_u_dt, carry.sum_u_tmid_dt,
                                         carry.sum_u_motor_dt) +
         earth_up_rate_rad_s * carry.span_s + carry.roll_pitch_term_rad;
}

Eigen::Matrix3d truth_attitude_at(const Dataset& ds, double t_s) {
  if (!ds.truth.empty()) {
    const TruthSample* best = &ds.truth.front();
    for (const TruthSample& s : ds.truth)
      if (std::abs(s.t_s - t_s) < std::abs(best->t_s - t_s)) best = &s;
    return C_b_n_from_euler(best->attitude);
  }
  if (!ds.meta.initial_attitude_known)
    throw std::invalid_argument(
        "--initial-attitude truth: this dataset has no truth.csv and its meta.json gives no "
        "initial attitude (measured data); use --initial-attitude level+heading (or gyrocompass "
        "on navigation-grade data)");
  return C_b_n_from_euler(ds.meta.initial.attitude);
}

namespace {

// --initial-attitude given: meta.json's attitude, which holds at initial.t_s; refused when it is
// not the one at the navigation start (the data between are neither static nor one IMU step).
Eigen::Matrix3d given_attitude(const Dataset& ds, const std::string& mode,
                               const AlignmentWindow& window, double window_start_t_s,
                               double t_nav0) {
  if (!ds.meta.initial_attitude_known)
    throw std::invalid_argument(
        mode +
        ": meta.json \"initial\" gives no attitude (roll_deg/pitch_deg/yaw_deg are "
        "null); use --initial-attitude level+heading on a static start, or write the "
        "attitude at the start into meta.json");
  // The attitude holds at initial.t_s; it is the one at the navigation start only while
  // the data between are static (inside the alignment window) or within one IMU step.
  const double step_s = 1.0 / ds.meta.imu_rate_hz;
  const double t_init = ds.meta.initial.t_s;
  const double earliest = (window.count > 0 ? window_start_t_s : t_nav0) - 1.5 * step_s;
  if (t_init < earliest || t_init > t_nav0 + 1.5 * step_s)
    throw std::invalid_argument(
        mode + ": meta.json \"initial\" is at t = " + number_text(t_init, 12) +
        " s, but the navigation starts at t = " + number_text(t_nav0, 12) +
        " s and the data between are not a static window; give the attitude at the "
        "navigation start");
  return C_b_n_from_euler(ds.meta.initial.attitude);
}

// Both window modes: a static window must exist and be static (the GNSS horizontal speed within
// options.static_max_speed_mps inside it).
void check_static_window(const Dataset& ds, const InitialAttitudeOptions& options,
                         const AlignmentWindow& window, std::size_t window_begin,
                         std::size_t window_end, double window_start_t_s, double t_nav0,
                         const std::string& mode) {
  if (window.count == 0)
    throw std::invalid_argument(
        "dataset has align_s = " + number_text(ds.meta.align_s, 12) +
        " s, less than one IMU step: no static window to level on, so " + mode +
        " cannot work (a vehicle already moving); give the attitude at the start: "
        "--initial-attitude given (meta.json \"initial\") or truth (simulated data)");
  for (std::size_t i = 0; i < ds.gnss.size(); ++i) {
    const GnssSample& g = ds.gnss[i];
    if (g.t_s < window_start_t_s - 1e-9 || g.t_s > t_nav0 + 1e-9) continue;
    const double speed = std::hypot(g.v_eb_n_mps.x(), g.v_eb_n_mps.y());
    if (speed > options.static_max_speed_mps)
      throw std::invalid_argument(
          "the alignment window (align_s = " + number_text(ds.meta.align_s, 12) +
          " s, imu.csv lines " + std::to_string(window_begin + 2) + "-" +
          std::to_string(window_end + 1) + ") is not static: the GNSS horizontal speed is " +
          number_text(speed, 3) + " m/s at t = " + number_text(g.t_s, 12) + " s (gnss.csv line " +
          std::to_string(i + 2) + "; static means <= " +
          number_text(options.static_max_speed_mps, 3) + " m/s), so " + mode +
          " cannot level on it; give a shorter align_s, or the attitude "
          "at the start: --initial-attitude given (meta.json \"initial\") or truth (simulated "
          "data)");
  }
}

// --heading-source measured: the circular mean of heading.csv's samples in the static window
// (the body does not turn there), else of the first ones after the navigation start within
// options.course_span_s (carried back like the course); `used` gets their rows.
MeasuredHeading mean_measured_heading(const Dataset& ds, const InitialAttitudeOptions& options,
                                      double window_start_t_s, double t_nav0,
                                      const std::string& mode, std::vector<std::size_t>& used) {
  MeasuredHeading m;
  m.kind = ds.meta.heading->source;
  m.declination_deg = ds.meta.heading->declination_deg;
  for (std::size_t i = 0; i < ds.heading.size(); ++i)
    if (ds.heading[i].t_s >= window_start_t_s - 1e-9 && ds.heading[i].t_s <= t_nav0 + 1e-9)
      used.push_back(i);
  m.carried = used.empty();
  if (m.carried) {
    const double t_last = ds.imu.back().t_s;
    for (std::size_t i = 0; i < ds.heading.size(); ++i) {
      const double t = ds.heading[i].t_s;
      if (t <= t_nav0 + 1e-9 || t > t_last + 1e-9) continue;
      if (!used.empty() && t > ds.heading[used.front()].t_s + options.course_span_s + 1e-9) break;
      used.push_back(i);
    }
  }
  if (used.empty())
    throw std::invalid_argument(
        mode + " --heading-source measured: heading.csv has no sample in the static window (t = " +
        number_text(window_start_t_s, 12) + " to " + number_text(t_nav0, 12) +
        " s) nor between the navigation start and the last IMU row (its samples run from t = " +
        number_text(ds.heading.front().t_s, 12) + " to " + number_text(ds.heading.back().t_s, 12) +
        " s)");
  double s = 0.0, c = 0.0, sum_var = 0.0;
  bool all_sd = true;
  for (std::size_t i : used) {
    s += std::sin(ds.heading[i].yaw_rad);
    c += std::cos(ds.heading[i].yaw_rad);
    if (ds.heading[i].sd_rad)
      sum_var += *ds.heading[i].sd_rad * *ds.heading[i].sd_rad;
    else
      all_sd = false;
  }
  const double n = static_cast<double>(used.size());
  m.count = used.size();
  m.first_line = used.front() + 2;
  m.t_first_s = ds.heading[used.front()].t_s;
  m.t_last_s = ds.heading[used.back()].t_s;
  m.mean_rad = std::atan2(s, c);
  const double R = std::min(1.0, std::hypot(s, c) / n);
  m.scatter_rad = R > 0.0 ? std::sqrt(std::max(0.0, -2.0 * std::log(R))) : kPi;
  if (all_sd) m.sample_sd_rad = std::sqrt(sum_var / n);
  m.sd_rad = std::max(m.sample_sd_rad.value_or(0.0), m.scatter_rad) / std::sqrt(n);
  return m;
}

// The GNSS course fixes: the first epoch after the navigation start with a horizontal speed of at
// least options.course_min_speed_mps, and the fast ones within options.course_span_s after it;
// refused when the speed never gets there.
std::vector<CourseFix> gnss_course_fixes(const Dataset& ds, const InitialAttitudeOptions& options,
                                         double t_nav0, const std::string& mode) {
  std::vector<CourseFix> fixes;
  const double t_last = ds.imu.back().t_s;
  double max_speed = 0.0, t_max_speed = t_nav0;
  for (std::size_t i = 0; i < ds.gnss.size(); ++i) {
    const GnssSample& g = ds.gnss[i];
    if (g.t_s <= t_nav0 + 1e-9 || g.t_s > t_last + 1e-9) continue;
    const double speed = std::hypot(g.v_eb_n_mps.x(), g.v_eb_n_mps.y());
    if (speed > max_speed) max_speed = speed, t_max_speed = g.t_s;
    if (!fixes.empty() && g.t_s > fixes.front().t_s + options.course_span_s + 1e-9) break;
    if (!(speed >= options.course_min_speed_mps)) continue;
    CourseFix fix;
    fix.gnss_index = i;
    fix.t_s = g.t_s;
    fix.course_rad = std::atan2(g.v_eb_n_mps.x(), g.v_eb_n_mps.y());
    fix.speed_mps = speed;
    fixes.push_back(fix);
  }
  if (fixes.empty())
    throw std::invalid_argument(
        mode + ": the GNSS horizontal speed never reaches " +
        number_text(options.course_min_speed_mps, 3) +
        " m/s after the navigation start (t = " + number_text(t_nav0, 12) + " s; the fastest is " +
        number_text(max_speed, 3) + " m/s at t = " + number_text(t_max_speed, 12) +
        " s), so the course gives no heading; give it with --heading-deg H");
  return fixes;
}

// The sums of every fix (yaw_change_rad) for a reference attitude track starting at C_b_n0 at the
// navigation start: C_b_n(t + dt) = Rot(-omega_ie_n dt) C_b_n(t) Rot(dtheta_b - b_ref dt).
std::vector<YawCarry> carry_sums(const Dataset& ds, const std::vector<CourseFix>& fixes,
                                 const Eigen::Matrix3d& C_b_n0, const Eigen::Vector3d& omega_ie_n,
                                 const Eigen::Vector3d& b_ref, std::size_t nav_begin,
                                 const std::string& mode) {
  std::vector<YawCarry> out(fixes.size());
  Eigen::Matrix3d C_ref = C_b_n0;
  YawCarry sums;
  std::size_t next_fix = 0;
  EulerAngles e_prev = euler_from_C_b_n(C_ref);
  for (std::size_t k = nav_begin; k < ds.imu.size() && next_fix < fixes.size(); ++k) {
    const double t_prev = ds.imu[k - 1].t_s, t_k = ds.imu[k].t_s, dt = t_k - t_prev;
    if (!(dt > 0.0))
      throw std::invalid_argument(mode + ": IMU time stamps not increasing at imu.csv line " +
                                  std::to_string(k + 2));
    const Eigen::Vector3d& dtheta = ds.imu[k].dtheta_b_rad;
    const Eigen::Vector3d u_prev = C_ref.row(2).transpose();
    C_ref = quat_from_rotation_vector(-omega_ie_n * dt).toRotationMatrix() * C_ref *
            quat_from_rotation_vector(dtheta - b_ref * dt).toRotationMatrix();
    const Eigen::Vector3d u_mid = (u_prev + C_ref.row(2).transpose()).normalized();
    const EulerAngles e = euler_from_C_b_n(C_ref);
    const double t_mid = t_k - 0.5 * dt;
    YawCarry step;
    step.sum_u_dtheta = u_mid * dtheta.transpose();
    step.sum_u_dt = u_mid * dt;
    step.sum_u_tmid_dt = u_mid * (t_mid * dt);
    if (!ds.meta.motors.empty())
      step.sum_u_motor_dt = u_mid * (ds.meta.motors.fraction(t_prev, t_k) * dt);
    step.span_s = dt;
    step.roll_pitch_term_rad =
        std::sin(0.5 * (e.pitch_rad + e_prev.pitch_rad)) * wrap_pi(e.roll_rad - e_prev.roll_rad);
    e_prev = e;
    // Fixes inside (t_prev, t_k]: the sums so far plus the fraction of this step.
    while (next_fix < fixes.size() && fixes[next_fix].t_s <= t_k + 1e-9) {
      const double w = std::clamp((fixes[next_fix].t_s - t_prev) / dt, 0.0, 1.0);
      YawCarry& c = out[next_fix];
      c.sum_u_dtheta = sums.sum_u_dtheta + w * step.sum_u_dtheta;
      c.sum_u_dt = sums.sum_u_dt + w * step.sum_u_dt;
      c.sum_u_tmid_dt = sums.sum_u_tmid_dt + w * step.sum_u_tmid_dt;
      c.sum_u_motor_dt = sums.sum_u_motor_dt + w * step.sum_u_motor_dt;
      c.span_s = sums.span_s + w * step.span_s;
      c.roll_pitch_term_rad = sums.roll_pitch_term_rad + w * step.roll_pitch_term_rad;
      ++next_fix;
    }
    sums.sum_u_dtheta += step.sum_u_dtheta;
    sums.sum_u_dt += step.sum_u_dt;
    sums.sum_u_tmid_dt += step.sum_u_tmid_dt;
    sums.sum_u_motor_dt += step.sum_u_motor_dt;
    sums.span_s += step.span_s;
    sums.roll_pitch_term_rad += step.roll_pitch_term_rad;
  }
  if (next_fix < fixes.size())  // (fixes are at or before the last IMU row)
    throw std::logic_error("level+heading: course epoch after the last IMU row");
  return out;
}

}  // namespace

InitialAttitude::InitialAttitude(const Dataset& ds, const InitialAttitudeOptions& options,
                                 const AlignmentWindow& window, std::size_t window_begin,
                                 std::size_t window_end, double window_start_t_s,
                                 std::size_t nav_begin)
    : options_(options), window_(window) {
  if (const std::string why = options.validate(); !why.empty())
    throw std::invalid_argument("initial attitude: " + why);
  const double t_nav0 = ds.imu[nav_begin - 1].t_s;
  const double lat0 = interpolate_gnss(ds.gnss, t_nav0).lat_rad;
  const EarthModel& earth = ds.meta.earth;
  earth_up_rate_rad_s_ = earth.omega_ie_rad_s * std::sin(lat0);
  const std::string mode = "--initial-attitude " + to_string(options.mode);

  switch (options.mode) {
    case InitialAttitudeMode::kTruth:
      C_b_n_fixed_ = truth_attitude_at(ds, t_nav0);
      return;
    case InitialAttitudeMode::kGiven:
      C_b_n_fixed_ = given_attitude(ds, mode, window, window_start_t_s, t_nav0);
      return;
    case InitialAttitudeMode::kGyrocompass:
    case InitialAttitudeMode::kLevelHeading:
      break;
  }

  check_static_window(ds, options, window, window_begin, window_end, window_start_t_s, t_nav0,
                      mode);

  if (options.mode == InitialAttitudeMode::kGyrocompass) {
    const bool declared = ds.meta.noise.has_value();
    const double arw =
        declared ? ds.meta.noise->arw_deg_rth / kRadRtsToDegRth
                 : estimate_arw_rad_rts(ds.imu, window_begin, window_end, window_start_t_s);
    feasibility_ =
        gyrocompass_feasibility(arw, declared, window.sum_dt_s, options.gyro_bias_allowance_rad_s,
                                earth.omega_ie_rad_s, lat0);
    if (!(feasibility_->heading_sd_rad * kRadToDeg <= options.gyrocompass_max_heading_sd_deg))
      throw std::invalid_argument(
          mode + " refused: " + feasibility_->describe() + " exceeds the threshold of " +
          number_text(options.gyrocompass_max_heading_sd_deg, 3) +
          " deg: the gyros cannot sense the Earth rate well enough for a heading (MEMS grade?); "
          "use --initial-attitude level+heading (heading from the GNSS course, or "
          "--heading-deg H)");
    return;
  }

  // level+heading. A given heading needs nothing more.
  if (options.effective_heading_source() == HeadingSource::kGiven) return;
  if (options.effective_heading_source() == HeadingSource::kMeasured) {
    if (ds.heading.empty() || !ds.meta.heading)
      throw std::invalid_argument(
          mode +
          " --heading-source measured: this dataset has no measured heading (no heading.csv); "
          "bring one with insid import (csv: a hdg column, or mx,my,mz with --declination-deg; "
          "ulog: --heading gps|mag) or insid simulate --heading, or take the heading from "
          "--heading-source course or --heading-deg H");
    std::vector<std::size_t> used;
    const MeasuredHeading m =
        mean_measured_heading(ds, options, window_start_t_s, t_nav0, mode, used);
    measured_ = m;
    if (!m.carried) return;
    for (std::size_t i : used) {
      CourseFix fix;
      fix.gnss_index = i;  // the heading.csv row
      fix.t_s = ds.heading[i].t_s;
      fix.course_rad = ds.heading[i].yaw_rad;
      fix.speed_mps = 0.0;
      fixes_.push_back(fix);
    }
  }
  if (fixes_.empty()) fixes_ = gnss_course_fixes(ds, options, t_nav0, mode);  // the GNSS course

  // Carry each course back to the start along a reference attitude track from the levelled start
  // (yaw 0: the track's tilt, which is all the carry uses, does not depend on it),
  // C_b_n(t + dt) = Rot(-omega_ie_n dt) C_b_n(t) Rot(dtheta_b - b_ref dt) (the transport rate is
  // left out as in yaw_change_rad). The track is only where the carry is linearised (the
  // candidate's gyros enter through the sums), but a MEMS gyro bias of 0.2 deg/s would tilt it
  // by 2 deg in 10 s: b_ref is the static window's mean rate less the vertical Earth rate, which
  // leaves at most the horizontal Earth rate (W cos lat, 0.003 deg/s) as the track's drift.
  const Eigen::Vector3d f_raw_b = window.sum_dv_b / window.sum_dt_s;
  const Eigen::Matrix3d C_start = level_with_yaw(f_raw_b, 0.0);
  reference_tilt_ = euler_from_C_b_n(C_start);
  const Eigen::Vector3d omega_ie_n = earth.omega_ie_n(lat0);
  const Eigen::Vector3d b_ref = window.sum_dtheta_b / window.sum_dt_s -
                                earth_up_rate_rad_s_ * Eigen::Vector3d(C_start.row(2).transpose());

  // The sums of every fix for a track starting at C_b_n0.
  const auto carries = [&](const Eigen::Matrix3d& C_b_n0) {
    return carry_sums(ds, fixes_, C_b_n0, omega_ie_n, b_ref, nav_begin, mode);
  };
  const std::vector<YawCarry> base = carries(C_start);
  // Sensitivity to the start's roll and pitch, by central differences of 1 mrad, evaluated with
  // the track's own gyros (b_ref removed).
  constexpr double kTiltStep = 1e-3;
  SensorErrors debias;
  debias.gyro.bias = b_ref;
  const ImuCompensator track_gyros(debias);
  const auto tilted = [&](double droll, double dpitch) {
    EulerAngles e = reference_tilt_;
    e.roll_rad += droll;
    e.pitch_rad += dpitch;
    return carries(C_b_n_from_euler(e));
  };
  const std::vector<YawCarry> roll_p = tilted(kTiltStep, 0), roll_m = tilted(-kTiltStep, 0);
  const std::vector<YawCarry> pitch_p = tilted(0, kTiltStep), pitch_m = tilted(0, -kTiltStep);
  const auto change = [&](const YawCarry& c) {
    return yaw_change_rad(c, track_gyros, earth_up_rate_rad_s_);
  };
  for (std::size_t f = 0; f < fixes_.size(); ++f) {
    fixes_[f].carry = base[f];
    fixes_[f].dyaw_droll0 = (change(roll_p[f]) - change(roll_m[f])) / (2 * kTiltStep);
    fixes_[f].dyaw_dpitch0 = (change(pitch_p[f]) - change(pitch_m[f])) / (2 * kTiltStep);
  }
}

EulerAngles InitialAttitude::tilt_offset(const ImuCompensator& compensator) const {
  // The candidate's levelling, against the reference track's start.
  Eigen::Vector3d omega_ib_b = window_.sum_dtheta_b / window_.sum_dt_s;
  Eigen::Vector3d f_ib_b = window_.sum_dv_b / window_.sum_dt_s;
  compensator.compensate_mean(window_.mean_t_mid_s, omega_ib_b, f_ib_b, window_.mean_motor_on);
  const EulerAngles tilt = euler_from_C_b_n(level_with_yaw(f_ib_b, 0.0));
  EulerAngles d;
  d.roll_rad = wrap_pi(tilt.roll_rad - reference_tilt_.roll_rad);
  d.pitch_rad = tilt.pitch_rad - reference_tilt_.pitch_rad;
  return d;
}

double InitialAttitude::yaw_change_to(const CourseFix& fix, const ImuCompensator& compensator,
                                      const EulerAngles& tilt_offset) const {
  return yaw_change_rad(fix.carry, compensator, earth_up_rate_rad_s_) +
         fix.dyaw_droll0 * tilt_offset.roll_rad + fix.dyaw_dpitch0 * tilt_offset.pitch_rad;
}

double InitialAttitude::yaw_change_to(const CourseFix& fix,
                                      const ImuCompensator& compensator) const {
  return yaw_change_to(fix, compensator, tilt_offset(compensator));
}

double InitialAttitude::level_heading_yaw_rad(const ImuCompensator& compensator) const {
  if (options_.heading_deg) return *options_.heading_deg * kDegToRad;
  // A measured heading in the static window holds at the navigation start for every candidate.
  if (measured_ && !measured_->carried) return measured_->mean_rad;
  const EulerAngles offset = tilt_offset(compensator);
  // Circular mean of the courses carried back to the start: psi_0 = course - delta psi.
  double s = 0.0, c = 0.0;
  for (const CourseFix& fix : fixes_) {
    const double psi0 = fix.course_rad - yaw_change_to(fix, compensator, offset);
    s += std::sin(psi0);
    c += std::cos(psi0);
  }
  return std::atan2(s, c);
}

Eigen::Matrix3d InitialAttitude::attitude(const ImuCompensator& compensator) const {
  switch (options_.mode) {
    case InitialAttitudeMode::kGyrocompass:
      return align_window(window_, compensator);
    case InitialAttitudeMode::kLevelHeading: {
      Eigen::Vector3d omega_ib_b = window_.sum_dtheta_b / window_.sum_dt_s;
      Eigen::Vector3d f_ib_b = window_.sum_dv_b / window_.sum_dt_s;
      compensator.compensate_mean(window_.mean_t_mid_s, omega_ib_b, f_ib_b, window_.mean_motor_on);
      return level_with_yaw(f_ib_b, level_heading_yaw_rad(compensator));
    }
    case InitialAttitudeMode::kGiven:
    case InitialAttitudeMode::kTruth:
      break;
  }
  return C_b_n_fixed_;
}

}  // namespace insid
