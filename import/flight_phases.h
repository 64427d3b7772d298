// The phases of a multicopter flight found in its log: on the ground, motors spinning
// up, airborne, and how it ended (a crash or upset, a landing, or the end of the log), on the
// autopilot's boot clock, so that a user can choose the part to import (--t-start / --t-end) and
// cut a crash out. Found from the IMU (specific force and angular rate, body FRD) and the GNSS
// fixes (altitude and horizontal speed), never from the autopilot's own state (its arming or
// flight-mode records), so that the same rules serve any log with an IMU and a GPS.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace insid::importers {

struct FlightPhaseOptions {
  double block_s = 0.5;  ///< IMU blocks (s) in which the scatter and the attitude are judged
  /// Sample sd of |specific force| in a block (m/s^2) above which a block "spins": a still
  /// multicopter's MEMS accelerometer scatters ~0.01 m/s^2 at 50 Hz (log171.bin: 0.011-0.012),
  /// spinning propellers 0.1-0.7 (log171.bin in flight: 0.096 at the quietest, median 0.27).
  double spin_accel_sd_mps2 = 0.08;
  /// The motors turn from the first spinning block from which at least spin_fraction of the
  /// spin_window_blocks blocks spin (and stop at the first still block from which as many are
  /// still): handling on the ground scatters a few blocks as much (log171.bin at 27-28.5 s: 3
  /// blocks, 0.6-1.4 m/s^2, with rates of 40-60 deg/s), propellers keep on for the whole flight.
  int spin_window_blocks = 10;
  double spin_fraction = 0.8;
  /// Take-off: the first GNSS fix after the spin-up above the ground altitude (the median of the
  /// fixes before it) by climb_m, or faster than speed_mps horizontally. A GPS altitude
  /// scatters by ~0.2 m (sd) on the ground (log171.bin: 0.22 m, range 0.85 m over 38 s).
  double climb_m = 1.0;
  double speed_mps = 1.0;
  /// A crash: a sample whose |specific force| exceeds impact_g (standard g): a multicopter's
  /// manoeuvres stay below ~2 g (log171.bin: 1.6 g in 150 s of flight, Acro included), an impact
  /// on the ground reaches 5-50 g (log171.bin: 11 g).
  double impact_g = 4.0;
  /// Upside down: a block whose mean body-z specific force exceeds +inverted_g (FRD: still and
  /// upright it is -1 g). Counts as the end of the flight as a crash does.
  double inverted_g = 0.5;
  /// Landing (without a crash): the motors stop (a run of still blocks, as above) within
  /// landed_m of the ground altitude.
  double landed_m = 2.0;
  /// The --t-end suggested before a crash: this long before it (s), so that the upset that
  /// leads into an impact (a flip, a fall) stays out.
  double crash_margin_s = 2.0;
  std::string validate() const;
};

struct FlightPhaseInput {
  std::vector<double> imu_boot_s;         ///< increasing
  std::vector<Eigen::Vector3d> f_b_mps2;  ///< specific force, body FRD
  std::vector<Eigen::Vector3d> omega_b_rad_s;
  std::vector<double> gnss_boot_s;  ///< fixes only, increasing
  std::vector<double> gnss_alt_m, gnss_speed_mps;
};

struct FlightPhases {
  double log_start_s = 0.0, log_end_s = 0.0;  ///< the IMU's first and last record
  std::optional<double> gnss_fix_from_s;      ///< the first fix
  std::optional<double> motors_on_s;          ///< start of the first block of the spin-up
  std::optional<double> takeoff_s;            ///< the take-off fix
  double ground_alt_m = 0.0;                  ///< median GPS altitude before the spin-up
  std::optional<double> crash_s;              ///< the first impact sample
  std::optional<double> inverted_s;           ///< start of the first upside-down block
  std::optional<double> landed_s;             ///< motors stopped near the ground
  double airborne_end_s = 0.0;                ///< crash, upside down, landing or the log's end (s)
  std::string ended_by;                       ///< "crash" | "inverted" | "landing" | "end of log"
  double peak_airborne_g = 0.0, peak_airborne_rate_deg_s = 0.0;  ///< up to airborne_end_s
  /// A window for `insid import ardupilot`: from the first record (or the end of the last IMU
  /// logging gap on the ground) to airborne_end_s less crash_margin_s after a crash.
  double suggest_t_start_s = 0.0, suggest_t_end_s = 0.0;
  double climb_m = 0.0, speed_mps = 0.0;  ///< the take-off thresholds used (for the report)
  bool airborne() const { return takeoff_s.has_value(); }
  nlohmann::json to_json() const;
  std::vector<std::string> lines() const;  ///< the report for the user, one phase a line
};

/// Finds the phases. `ground_gaps_end_s`: ends of IMU logging gaps (boot s) that the suggested
/// window should start after when they lie before the take-off. Throws std::invalid_argument on
/// inconsistent input (sizes, no IMU records).
FlightPhases find_flight_phases(const FlightPhaseInput& in, const FlightPhaseOptions& options,
                                const std::vector<double>& ground_gaps_end_s = {});

}  // namespace insid::importers
