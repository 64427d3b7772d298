// The gyros' reading at rest, as a measurement of their bias (a zero-rate update, Groves 2013
// sec. 15.3.3, made once over the static window).
//
// A gyro triad at rest measures the Earth rate: over the alignment window its mean reading is
//   omega_bar = G omega_ie_b + b0 + b_dot t_mid + b_motor u_bar + noise,
// G = I + S + M, omega_ie_b = C_n_b omega_ie_n(lat) (model/sensor_errors.h, model/earth.h),
// t_mid the window's dt-weighted mean time and u_bar the part of it the motors ran. Solved for
// b0 given the other gyro terms, it fixes the motors-off bias from the window alone; the flight
// then sees b0 + b_motor while the motors run, so the motor offset becomes observable without
// any motors-off navigation (a MEMS drone re-zeroes its gyros at arming and starts its motors
// seconds later). The Earth rate is at most 0.0042 deg/s; it is taken with the attitude of the
// data as recorded (an attitude error e moves it by about e times that rate: 1 deg, 7e-5 deg/s).
// The window's noise (angle random walk over its span) reaches the estimates through the noise
// replicas of the uncertainty, which re-measure the mean on each replica.
#pragma once

#include <string>
#include <string_view>

#include <Eigen/Core>

#include "model/sensor_errors.h"
#include "nav/fitness.h"

namespace insid {

struct GyroAtRest {
  Eigen::Vector3d mean_omega_ib_b = Eigen::Vector3d::Zero();  ///< mean gyro reading (rad/s)
  Eigen::Vector3d omega_ie_b = Eigen::Vector3d::Zero();       ///< Earth rate in b (rad/s)
  double t_mid_s = 0.0;        ///< the window's dt-weighted mean sample mid-time (s)
  double motor_on_mean = 0.0;  ///< part of the window the motors ran (0: refused otherwise)
  double t_begin_s = 0.0;      ///< the window (s, dataset time)
  double t_end_s = 0.0;
  std::size_t samples = 0;
  /// The mean's standard error for white noise: the rates' spread over sqrt(samples) (rad/s;
  /// what the static window itself says, vibration-free, so the samples are close to white).
  Eigen::Vector3d sd_of_mean_rad_s = Eigen::Vector3d::Zero();

  /// The b0 that makes the window's compensated mean rate equal the Earth rate, given the
  /// other gyro terms of `gyro` (its own b0 is not read).
  Eigen::Vector3d bias_for(const TriadErrors& gyro) const {
    return mean_omega_ib_b - gyro.distortion() * omega_ie_b - gyro.bias_drift * t_mid_s -
           gyro.motor_offset * motor_on_mean;
  }
};

/// True for the effects a rest measurement fixes instead of a search: the gyro biases b0
/// (gyro_bias_x|y|z). Unknown names are not.
bool measured_at_rest(std::string_view effect_name);

/// The alignment window of `navigation` as a rest measurement. Throws std::invalid_argument
/// naming why it cannot be one: no window (align_s = 0), the motors ran in it, or the initial
/// attitude is found by gyrocompassing (which reads the same window's rate as the Earth rate, so
/// the window cannot measure the bias too).
GyroAtRest gyro_at_rest(const NavigationProblem& navigation);

}  // namespace insid
