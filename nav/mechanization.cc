#include "nav/mechanization.h"

#include <cmath>

#include "model/rotation.h"

namespace insid {

Strapdown::Strapdown(const EarthModel& earth, const NavState& initial, const ImuSample& previous,
                     double previous_dt_s)
    : earth_(earth),
      state_(initial),
      prev_state_(initial),
      prev_inc_(previous),
      prev_dt_s_(previous_dt_s) {}

void Strapdown::step(const ImuSample& inc) { update(inc); }

void Strapdown::step_aided(const ImuSample& inc, double h_ref_m, double vU_ref_mps) {
  update(inc);
  state_.h_m = h_ref_m;
  state_.v_eb_n.z() = vU_ref_mps;
}

void Strapdown::update(const ImuSample& inc) {
  const NavState old = state_;
  const double dt = inc.t_s - old.t_s;
  const Eigen::Vector3d& dtheta = inc.dtheta_b_rad;
  const Eigen::Vector3d& dv = inc.dv_b_mps;
  const Eigen::Vector3d& dtheta_prev = prev_inc_.dtheta_b_rad;
  const Eigen::Vector3d& dv_prev = prev_inc_.dv_b_mps;

  // --- 1. Velocity (Eq. 1, row 2). Mid-interval position/velocity extrapolated from the last
  // two states (first order), used for gravity, Earth rate, transport rate and Coriolis.
  const Eigen::Vector3d v_mid = 1.5 * old.v_eb_n - 0.5 * prev_state_.v_eb_n;
  const double lat_mid = 1.5 * old.lat_rad - 0.5 * prev_state_.lat_rad;
  const double h_mid = 1.5 * old.h_m - 0.5 * prev_state_.h_m;
  const Eigen::Vector3d omega_ie_n = earth_.omega_ie_n(lat_mid);
  const Eigen::Vector3d omega_en_n = earth_.omega_en_n(lat_mid, h_mid, v_mid);
  const Eigen::Vector3d zeta_n = (omega_ie_n + omega_en_n) * dt;  // n-frame rotation over dt

  // Rotation and two-sample sculling corrections (Savage 2000, Eq. 7.2.2.2-22 form; divisor 12
  // for equal steps, the measured steps' own otherwise: two_sample_divisor).
  const double two_sample = two_sample_divisor(prev_dt_s_, dt);
  const Eigen::Vector3d dv_rot_b = 0.5 * dtheta.cross(dv);
  const Eigen::Vector3d dv_scul_b = (dtheta_prev.cross(dv) + dv_prev.cross(dtheta)) / two_sample;
  const Eigen::Vector3d dv_sf_b = dv + dv_rot_b + dv_scul_b;
  const Eigen::Matrix3d C_b_n_old = old.q_b_n.toRotationMatrix();
  const Eigen::Vector3d dv_sf_n =
      (Eigen::Matrix3d::Identity() - 0.5 * skew(zeta_n)) * (C_b_n_old * dv_sf_b);
  const Eigen::Vector3d dv_gcor_n =
      (earth_.gravity_n(lat_mid, h_mid) - (2.0 * omega_ie_n + omega_en_n).cross(v_mid)) * dt;
  NavState next = old;
  next.t_s = inc.t_s;
  next.v_eb_n = old.v_eb_n + dv_sf_n + dv_gcor_n;

  // --- 2. Position (Eq. 1 row 1 with D^-1 of Eq. 2), trapezoidal in velocity.
  const Eigen::Vector3d v_avg = 0.5 * (old.v_eb_n + next.v_eb_n);
  next.h_m = old.h_m + v_avg.z() * dt;
  const double h_avg = 0.5 * (old.h_m + next.h_m);
  next.lat_rad = old.lat_rad + v_avg.y() / (earth_.meridian_radius_m(old.lat_rad) + h_avg) * dt;
  const double lat_avg = 0.5 * (old.lat_rad + next.lat_rad);
  next.lat_rad = old.lat_rad + v_avg.y() / (earth_.meridian_radius_m(lat_avg) + h_avg) * dt;
  const double lat_avg2 = 0.5 * (old.lat_rad + next.lat_rad);
  next.lon_rad =
      old.lon_rad +
      v_avg.x() / ((earth_.prime_vertical_radius_m(lat_avg2) + h_avg) * std::cos(lat_avg2)) * dt;

  // --- 3. Attitude (Eq. 3): q_b_n(k) = q_n(k-1)_n(k) * q_b_n(k-1) * q_b(k)_b(k-1).
  // Body rotation vector with the two-sample coning correction (Savage Eq. 7.1.1.1-11).
  const Eigen::Vector3d phi_b = dtheta + dtheta_prev.cross(dtheta) / two_sample;
  // n-frame rotation over the step at the true mid-point.
  const Eigen::Vector3d v_mid2 = v_avg;
  const Eigen::Vector3d zeta_mid_n =
      (earth_.omega_ie_n(lat_avg2) + earth_.omega_en_n(lat_avg2, h_avg, v_mid2)) * dt;
  next.q_b_n =
      quat_from_rotation_vector(-zeta_mid_n) * old.q_b_n * quat_from_rotation_vector(phi_b);
  next.q_b_n.normalize();

  omega_ib_b_ = dt > 0 ? Eigen::Vector3d(dtheta / dt) : Eigen::Vector3d::Zero();
  prev_state_ = old;
  prev_inc_ = inc;
  prev_dt_s_ = dt;
  state_ = next;
}

}  // namespace insid
