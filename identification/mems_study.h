// Identification of a simulated MEMS flight within its stated sd: the flight, the
// two methods (EKF-RTS and LM on the windowed fitness) and one trial per noise seed. Used by
// mems_identification_test.cc and `insid-mems-study` (results/mems/). Links the scenarios, so it
// is a library of its own like window_study.
//
// Set-up (results/mems/README.md): the `rich` preset (takeoff, acceleration, turns both ways)
// with a 30 s static window and `flight_s` after it, MEMS noise (scenarios/noise.cc: ARW 0.2
// deg/sqrt(h), VRW 0.05 m/s/sqrt(h), GNSS velocity 0.03 m/s, position 0.5 m), biases on from
// t = 0: gyro (0.2, -0.15, 0.2) deg/s, accelerometer (20, -15, 0) mg (400 s: the takeoff,
// the first turns and speed changes). Initial attitude
// `level+heading` with the heading from the GNSS course (carried back to the start, per
// candidate), per-candidate alignment, the five estimated parameters gyro_bias_x|y|z and
// accel_bias_x|y with the mems grade's sigmas (0.1 deg/s, 10 mg) and the [-4, 4] sigma box.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "data/dataset.h"
#include "identification/ins_problem.h"
#include "identification/uncertainty.h"

namespace insid::mems_study {

struct Spec {
  double align_s = 30.0;
  double flight_s = 400.0;
  double window_s = 10.0;  ///< windowed fitness of the LM method (s)
  int replicas = 100;  ///< noise replicas of LM's and the swarm's sd (identification/uncertainty.h)
  std::string swarm = "dvpio";            ///< swarm method of the registry on the windowed fitness
  std::int64_t swarm_evaluations = 2000;  ///< its budget (fitness evaluations)
  std::uint64_t swarm_seed = 1;           ///< its random seed
  int threads = 0;                        ///< OpenMP threads (0 = default)
  int ekf_passes = 2;  ///< EKF-RTS passes (identification/ekf_rts.h, EkfRtsGradeSetup)
  double ekf_update_interval_s = 1.0;       ///< EKF-RTS GNSS update interval (s)
  double ekf_propagation_interval_s = 0.1;  ///< EKF-RTS covariance propagation step (s)
  int ekf_use_position = 1;                 ///< EKF-RTS: 1 GNSS position and velocity, 0 velocity
  std::string ekf_attitude = "level+heading";  ///< EKF-RTS initial-attitude mode
  /// A simulated dual-antenna heading in the flight (heading.csv: truth yaw + white noise of
  /// heading_sd_deg at 5 Hz; scenarios::add_heading_stream); 0 = none (the default).
  double heading_sd_deg = 0.0;
  /// level+heading's --heading-source for every method; "" = the course (the default).
  std::string heading_source;

  /// "rich" (the flight above, its five fixed biases) or "drone": a flight that looks like the
  /// shared ArduPilot quadcopter log (../shared/data/ardupilot-copter): the
  /// `multicopter` preset's legs, turns, climbs and orbits at drone_imu_rate_hz /
  /// drone_gnss_rate_hz after drone_align_s on the ground, flight_s of flying, white IMU noise at
  /// the levels measured in that log's flight (the simulator has no vibration model: drone_arw /
  /// drone_vrw stand for it), and six biases (gyro x/y/z, accel x/y/z) drawn per seed uniformly in
  /// [-truth_max_sigma, truth_max_sigma] grade sigma, searched in [-box_sigma, box_sigma].
  std::string kind = "rich";
  double drone_imu_rate_hz = 50.0;
  double drone_gnss_rate_hz = 5.0;
  double drone_align_s = 8.0;
  double drone_arw_deg_rth = 8.0;          ///< the log's in-flight gyro noise (deg/sqrt(h))
  double drone_vrw_mps_rth = 1.0;          ///< its in-flight accelerometer noise (m/s/sqrt(h))
  double drone_gnss_vel_sigma_mps = 0.05;  ///< per ENU axis (m/s)
  double drone_gnss_pos_sigma_m = 0.5;     ///< per ENU axis (m)
  double truth_max_sigma = 5.0;            ///< drone: biases uniform in +-this many grade sigma
  double box_sigma = 8.0;                  ///< drone: the search box +-this many grade sigma
  /// drone: meta.json declares the noise levels (the filter and the replicas then use the true
  /// ones); false: the data look imported, as the real log (no noise block: the EKF-RTS takes the
  /// grade's levels, the replicas the static window's).
  bool noise_in_meta = false;
  /// KEY=VALUE parameters of ekf_rts_reported's EKF-RTS (e.g. arw_deg_rth=0.2 vrw_mps_rth=0.05:
  /// the grade's levels, what it used before it measured the flight's noise).
  std::vector<std::string> ekf_params;
  /// "" when the spec can be run, else the first bad field and its value.
  std::string validate() const;
};

/// The five estimated parameters of the rich flight, in this order.
const std::vector<std::string>& parameter_names();
/// Its injected values (SI), in parameter_names() order.
Eigen::VectorXd truth_si();
/// The estimated parameters of `spec`'s flight (rich: the five; drone: six biases).
const std::vector<std::string>& parameter_names(const Spec& spec);
/// The injected values (SI) of `spec`'s flight for a seed (rich: truth_si(); drone: drawn from
/// the seed, the same on every platform).
Eigen::VectorXd truth_si(const Spec& spec, std::uint64_t seed);

/// The simulated flight for a noise seed.
std::shared_ptr<const Dataset> flight(const Spec& spec, std::uint64_t seed);

/// The identification problem on `data`: level+heading from the course, per-candidate
/// alignment, windowed fitness of `window_s` (0 = one run), the mems grade's box.
InsIdentificationProblem problem(const std::shared_ptr<const Dataset>& data, double window_s,
                                 int threads, const std::string& heading_source = "");

/// One method's answer: estimate and reported sd per parameter (SI, parameter_names() order),
/// and flags per parameter (LM: the uncertainty report's; EKF-RTS: none).
struct Answer {
  std::string method;
  Eigen::VectorXd estimate_si, sd_si;
  std::vector<std::vector<std::string>> flags;
  /// Through identify(): the uncertainty report (the parts each sd is made of).
  std::optional<UncertaintyReport> uncertainty;
  double wall_s = 0.0;
  std::int64_t evaluations = 0;  ///< fitness evaluations of the search (not the sd's)
};

/// EKF-RTS (grade-aware set-up, identification/ekf_rts.h): the smoothed biases at the
/// navigation start and the smoother's own sd.
Answer ekf_rts(const std::shared_ptr<const Dataset>& data, const Spec& spec);
/// EKF-RTS as `insid identify --algo ekf-rts` reports it (through identify(spec)): the
/// smoothed biases and the sd of identification/uncertainty.h's use_filter_sd.
Answer ekf_rts_reported(const std::shared_ptr<const Dataset>& data, const Spec& spec);
/// LM (the registry's "lm", 200 evaluations from the box centre) on the windowed fitness, sd
/// and flags from identification/uncertainty.h (least-squares criterion, noise replicas): run
/// through identify(spec) (identification/identify_run.h) as `insid identify` runs it.
Answer lm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec);
/// The swarm method `spec.swarm` (the registry's, default parameters, `swarm_evaluations`
/// evaluations, seed `swarm_seed`) on the windowed fitness (Eq. 15 summed over windows), sd and
/// flags from identification/uncertainty.h at its final point, as `insid identify` reports
/// them (through identify(spec)): the Gauss-Newton replica covariance, and not_converged when
/// one IRLS step of Eq. 15 from the final point moves a parameter by more than 1 sd.
Answer swarm_windowed(const std::shared_ptr<const Dataset>& data, const Spec& spec);

}  // namespace insid::mems_study
