// Smooth commanded drone trajectories built from flight segments (static, take-off, straight,
// speed change, coordinated turn, climb/descent, S-turns, loiter).
//
// The motion is described by five scalar channels, each piecewise constant with raised-cosine
// transitions, so every channel and its first derivative are continuous (no steps in angular
// rate or acceleration; only the second derivative jumps at a transition's ends):
//   Vh(t)  horizontal ground speed (m/s), along the heading (no sideslip, no wind)
//   vU(t)  vertical velocity (m/s)
//   r(t)   heading rate (rad/s); heading psi(t) = psi0 + integral of r (closed form)
//   theta_cmd(t), phi_cmd(t)  commanded pitch and roll offsets (rad)
// Attitude: yaw = psi, pitch = theta_cmd, roll = phi_cmd + atan(Vh r / g_ref) (coordinated
// bank). Velocity in n (ENU): v = (Vh sin psi, Vh cos psi, vU). Height h = h0 + integral of vU
// (closed form). Everything here is analytic in t, including the derivatives the IMU synthesis
// needs (dv/dt in n and the body rate w.r.t. n, omega_nb_b, from the Euler-angle rates).
// Latitude and longitude are not here: they are integrated in synthesis.h.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/rotation.h"
#include "model/units.h"

namespace insid::scenarios {

/// A scalar that is piecewise constant with raised-cosine transitions:
///   x(t) = from + (to - from) (1 - cos(pi tau / T)) / 2,  tau = t - t0 in [0, T].
/// Value and first derivative are continuous everywhere.
class SmoothChannel {
 public:
  explicit SmoothChannel(double initial = 0.0) : initial_(initial) {}

  /// Append a transition from the current final value to `target` over [t0_s, t0_s + T].
  /// Throws std::invalid_argument when T <= 0 or t0_s is before the end of the last one.
  void ramp(double t0_s, double duration_s, double target);

  double final_value() const { return ramps_.empty() ? initial_ : ramps_.back().to; }
  /// End of the last transition (-inf when none).
  double last_ramp_end_s() const;

  double value(double t_s) const;
  double rate(double t_s) const;
  /// Integral of the value from t = 0 to t_s (negative t_s allowed).
  double integral(double t_s) const;

  /// Appends the start and end times of every transition.
  void append_breakpoints(std::vector<double>& out) const;

 private:
  struct Ramp {
    double t0, T, from, to;
    double integral_at_t0;  // integral from 0 to t0
  };
  // Index of the last ramp with t0 <= t, or -1.
  int find(double t_s) const;

  double initial_;
  std::vector<Ramp> ramps_;
};

/// Analytic kinematic state of the trajectory at one time (IMU position aside from lat/lon).
struct Kinematics {
  double t_s = 0.0;
  double h_m = 0.0;
  Eigen::Vector3d v_eb_n = Eigen::Vector3d::Zero();  ///< (vE, vN, vU) (m/s)
  Eigen::Vector3d a_n = Eigen::Vector3d::Zero();     ///< d/dt of v_eb_n components (m/s^2)
  EulerAngles attitude;                              ///< (rad)
  Eigen::Matrix3d C_b_n = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_nb_b = Eigen::Vector3d::Zero();  ///< body rate w.r.t. n (rad/s)
};

/// Initial geodetic position and attitude of the vehicle (at t = 0).
struct InitialPose {
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double h_m = 0.0;
  EulerAngles attitude;
};

/// A built trajectory: the channels plus the initial pose.
class Trajectory {
 public:
  Trajectory() = default;

  const InitialPose& initial() const { return initial_; }
  /// Gravity used for the coordinated bank angle (m/s^2).
  double g_ref_mps2() const { return g_ref_; }

  Kinematics eval(double t_s) const;
  /// Sorted, unique times where a channel's second derivative jumps.
  std::vector<double> breakpoints() const;

 private:
  friend class TrajectoryBuilder;
  InitialPose initial_;
  double g_ref_ = kStandardGravity_mps2;
  SmoothChannel speed_;  // Vh (m/s)
  SmoothChannel vup_;    // vU (m/s)
  SmoothChannel turn_;   // heading rate (rad/s)
  SmoothChannel pitch_;  // pitch command (rad)
  SmoothChannel roll_;   // roll offset (rad)
};

enum class TurnDirection { kLeft = -1, kRight = 1 };

/// How sharp a turn is: exactly one of bank angle or turn rate.
struct TurnSharpness {
  double bank_rad = 0.0;    ///< coordinated bank angle, used when > 0
  double rate_rad_s = 0.0;  ///< heading rate, used when > 0
};

/// Appends segments one after another. Every method validates its arguments and throws
/// std::invalid_argument naming the bad value; the builder is unchanged after a throw.
class TrajectoryBuilder {
 public:
  /// Maximum bank angle and turn rate accepted.
  static constexpr double kMaxBankRad = 60.0 * kDegToRad;
  static constexpr double kMaxTurnRateRadS = 30.0 * kDegToRad;
  static constexpr double kMaxSpeedMps = 150.0;
  static constexpr double kMaxPitchRad = 45.0 * kDegToRad;

  TrajectoryBuilder(const InitialPose& initial, double g_ref_mps2);

  double now_s() const { return t_; }
  double speed_mps() const { return traj_.speed_.final_value(); }
  double vertical_speed_mps() const { return traj_.vup_.final_value(); }
  double height_m() const;

  /// Stand still (speed and vertical speed must be zero) for duration_s.
  void hold_static(double duration_s);
  /// Straight and level (whatever the current speed) for duration_s.
  void straight(double duration_s);
  /// Change horizontal speed to target_mps with mean acceleration accel_mps2 (> 0).
  void change_speed(double target_mps, double accel_mps2);
  /// Coordinated turn by turn_rad (> 0) with roll-in/roll-out ramps of ramp_s each.
  /// Total heading change = rate * (hold + ramp_s).
  void turn(double turn_rad, TurnDirection direction, const TurnSharpness& sharpness,
            double ramp_s);
  /// Height change dh_m (!= 0) at vertical speed vz_mps (> 0) with ramps of ramp_s; the pitch
  /// ramps to pitch_rad (when given, else to the flight-path angle when moving, else unchanged)
  /// and back to its previous value at the end.
  void climb(double dh_m, double vz_mps, double ramp_s, const double* pitch_rad = nullptr);
  /// Vertical take-off (must be stopped): climb by dh_m (> 0) at vz_mps.
  void takeoff(double dh_m, double vz_mps, double ramp_s);

  Trajectory build() const;

 private:
  double turn_rate_for(const TurnSharpness& sharpness) const;

  Trajectory traj_;
  double t_ = 0.0;
};

}  // namespace insid::scenarios
