// Strapdown mechanization in the local-level ENU frame from IMU increments (paper Eq. 1-3).
// This scalar version is the reference: clear code, correctness over speed.
//
// Per step (increments over (t_{k-1}, t_k]), following the two-sample algorithms of
// Savage (Strapdown Analytics, 2000, ch. 7) and Shin (2001, UCGE 20156) as also used by KF-GINS:
//   1. velocity: sculling-corrected specific-force increment rotated to n with the half-step
//      n-frame rotation, plus gravity and Coriolis at the extrapolated mid-point (Eq. 1, row 2);
//   2. position: trapezoidal latitude/longitude update with D^-1 (Eq. 1 row 1, Eq. 2);
//   3. attitude: coning-corrected body rotation vector and n-frame rotation over the step,
//      as quaternions (Eq. 3 integrated exactly for the rotation vector).
// Height and vertical velocity may be aided: replaced after each step by a reference (the
// paper takes height from an altimeter; docs/design.md sec. 2 "Vertical channel").
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "data/dataset.h"
#include "model/earth.h"

namespace insid {

/// Navigation state of the IMU: geodetic position, velocity w.r.t. Earth in n, attitude.
struct NavState {
  double t_s = 0.0;
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double h_m = 0.0;
  Eigen::Vector3d v_eb_n = Eigen::Vector3d::Zero();  ///< (vE, vN, vU) (m/s)
  Eigen::Quaterniond q_b_n = Eigen::Quaterniond::Identity();
};

/// Divisor of the two-sample coning and sculling cross products (Savage 2000, Eq. 7.1.1.1-11 and
/// 7.2.2.2-22) for a step of `dt_s` after one of `dt_prev_s`: with rates linear over both steps
/// the corrections are (dtheta_prev x dtheta) h^2 / (6 h_prev (h_prev + h)) (and likewise for
/// sculling), so the divisor is 6 h_prev (h_prev + h) / h^2: 12 for equal steps. Steps that agree
/// to 1e-9 (stamps k / rate in floating point differ in the last bits, not in timing) give
/// exactly 12, so constant-rate data navigate bit for bit as with the fixed 1/12.
inline double two_sample_divisor(double dt_prev_s, double dt_s) {
  if (!(dt_prev_s > 0.0) || std::fabs(dt_prev_s - dt_s) <= 1e-9 * dt_s) return 12.0;
  return 6.0 * dt_prev_s * (dt_prev_s + dt_s) / (dt_s * dt_s);
}

class Strapdown {
 public:
  /// `previous` is the (compensated) increment that ends at initial.t_s; it seeds the
  /// two-sample coning/sculling corrections (pass zero increments when unknown). `previous_dt_s`
  /// is its interval (0: unknown, taken as long as the first step).
  Strapdown(const EarthModel& earth, const NavState& initial, const ImuSample& previous,
            double previous_dt_s = 0.0);

  /// Free-inertial step with a compensated increment ending at inc.t_s.
  void step(const ImuSample& inc);
  /// Height-aided step: after the update, h and vU are replaced by the reference values.
  void step_aided(const ImuSample& inc, double h_ref_m, double vU_ref_mps);

  const NavState& state() const { return state_; }
  /// Angular rate of the last step's increment (rad/s), for lever-arm terms.
  const Eigen::Vector3d& omega_ib_b() const { return omega_ib_b_; }

 private:
  void update(const ImuSample& inc);

  EarthModel earth_;
  NavState state_;
  NavState prev_state_;  // state one step before state_, for mid-point extrapolation
  ImuSample prev_inc_;
  double prev_dt_s_ = 0.0;  // interval of prev_inc_ (s); 0 = unknown
  Eigen::Vector3d omega_ib_b_ = Eigen::Vector3d::Zero();
};

}  // namespace insid
