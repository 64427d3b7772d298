// Truth -> exact IMU increments -> GNSS antenna solution.
//
// Scheme (scenarios/README.md, "Synthesis"): the trajectory (trajectory.h) gives velocity,
// acceleration, height, attitude and the body rate w.r.t. n in closed form. The true angular
// rate and specific force follow from the ENU navigation equations read backwards:
//   omega_ib_b = omega_nb_b + C_n_b (omega_ie_n + omega_en_n)
//   f_ib_b     = C_n_b (dv_n/dt + (2 omega_ie_n + omega_en_n) x v_n - g_n)
// with the dataset's Earth model. Latitude and longitude, the only states not in closed form,
// are integrated with classical RK4 on sub-steps of each IMU interval, split at every channel
// breakpoint; the same RK4 stages integrate omega_ib_b and f_ib_b (Simpson's rule, fourth
// order) into the increments. Row k holds the increments over (t_k - dt, t_k].
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "data/dataset.h"
#include "model/earth.h"
#include "scenarios/trajectory.h"

namespace insid::scenarios {

/// The true IMU state at one time.
struct TrueState {
  double t_s = 0.0;
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double h_m = 0.0;
  Eigen::Vector3d v_eb_n = Eigen::Vector3d::Zero();  ///< (vE, vN, vU) (m/s)
  Eigen::Vector3d a_n = Eigen::Vector3d::Zero();     ///< d/dt v_eb_n (m/s^2)
  EulerAngles attitude;
  Eigen::Matrix3d C_b_n = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_nb_b = Eigen::Vector3d::Zero();  ///< (rad/s)
  Eigen::Vector3d omega_ib_b = Eigen::Vector3d::Zero();  ///< true gyro rate (rad/s)
  Eigen::Vector3d f_ib_b = Eigen::Vector3d::Zero();      ///< true specific force (m/s^2)
};

/// Integrates a trajectory at a fixed IMU rate and stores exact increments and truth.
class ImuSynthesizer {
 public:
  /// substeps: RK4 sub-steps per IMU interval (>= 1).
  ImuSynthesizer(Trajectory trajectory, const EarthModel& earth, double imu_rate_hz,
                 int substeps = 4);

  /// Generate IMU rows k = 1..num_steps at t_k = k / imu_rate_hz (the data start at t = 0), on
  /// `threads` OpenMP threads (the same rows for any count).
  void run(std::size_t num_steps, int threads = 1);

  const std::vector<ImuSample>& imu() const { return imu_; }
  const std::vector<TruthSample>& truth() const { return truth_; }
  /// The rows of run(), moved out (imu() and truth() are empty afterwards; state_at still works).
  std::vector<ImuSample> take_imu() { return std::move(imu_); }
  std::vector<TruthSample> take_truth() { return std::move(truth_); }
  const Trajectory& trajectory() const { return traj_; }
  const EarthModel& earth() const { return earth_; }
  double imu_rate_hz() const { return rate_; }

  /// True state at any time (before 0 and after the last row too: the motion holds).
  TrueState state_at(double t_s) const;

  /// Rates at time t for a latitude/longitude (the analytic part from the trajectory).
  TrueState state_from(const Kinematics& k, double lat_rad, double lon_rad) const;

 private:
  // Latitude/longitude with Kahan compensation terms (millions of tiny additions).
  struct GeoPos {
    double lat = 0.0, lon = 0.0;
    double lat_c = 0.0, lon_c = 0.0;
  };
  // One RK4 sub-step [ta, tb] of length h as advance() cuts an IMU interval, with what run()
  // finds for it in order: the latitudes of its four stages, the longitude at its start, the
  // position at its end.
  struct SubStep {
    double ta, tb, h;
    double lat = 0.0, lat2 = 0.0, lat3 = 0.0, lat4 = 0.0, lon = 0.0;
    double lat_end = 0.0, lon_end = 0.0;
  };
  // Calls piece(a, b, n) for each piece of [t0, t1] (either direction) cut at the breakpoints
  // strictly inside it, in the direction of travel, with its n RK4 sub-steps.
  template <class Piece>
  void for_each_piece(double t0, double t1, Piece&& piece) const;
  // Integrate lat/lon from t0 to t1 (either direction), accumulating the increments when given.
  void advance(double t0, double t1, GeoPos& p, Eigen::Vector3d* dtheta, Eigen::Vector3d* dv) const;
  void advance_piece(double t0, double t1, int n, GeoPos& p, Eigen::Vector3d* dtheta,
                     Eigen::Vector3d* dv) const;

  Trajectory traj_;
  EarthModel earth_;
  double rate_;
  int substeps_;
  std::vector<double> breakpoints_;
  std::vector<double> lat_grid_, lon_grid_;  // at t_k, k = 0..K
  std::vector<ImuSample> imu_;
  std::vector<TruthSample> truth_;
};

/// Geodetic <-> ECEF on the model's ellipsoid.
Eigen::Vector3d ecef_from_geodetic(const EarthModel& earth, double lat_rad, double lon_rad,
                                   double h_m);
void geodetic_from_ecef(const EarthModel& earth, const Eigen::Vector3d& r_e, double& lat_rad,
                        double& lon_rad, double& h_m);
/// C_n_e: ENU at (lat, lon) to ECEF.
Eigen::Matrix3d C_n_e(double lat_rad, double lon_rad);

/// Exact GNSS antenna solution for an antenna at lever_arm_b_m (body) from the IMU:
/// position r_e + C_b_e l; velocity v_e + C_b_e (omega_eb_b x l) expressed in the antenna's own
/// ENU frame, omega_eb_b = omega_ib_b - C_n_b omega_ie_n. No noise. t_s is set to s.t_s.
GnssSample antenna_solution(const EarthModel& earth, const TrueState& s,
                            const Eigen::Vector3d& lever_arm_b_m);

}  // namespace insid::scenarios
