// From an ArduPilot DataFlash log to the IMU samples and GNSS solution that assemble_dataset
// takes (`insid import ardupilot`). IMU records carry the boot clock (TimeMS, ms since boot);
// GPS records carry GPS week and time of week (Week, TimeMS) and the boot clock when logged (T).
// A linear fit of GPST against T over the fixes puts the IMU on GPST, the scale of the other
// importers (gnss_solution.h).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "import/csv_imu.h"
#include "import/dataflash.h"
#include "import/flight_phases.h"
#include "import/gnss_solution.h"
#include "import/motor_state.h"

namespace insid::importers {

struct ArduPilotImportOptions {
  std::string imu = "IMU";  ///< the IMU message: IMU, IMU2 or IMU3 (one physical IMU each)
  int min_status = 3;       ///< GPS Status kept: 3 = 3D fix and above
  std::optional<double> t_start_s, t_end_s;  ///< boot seconds: records outside are cut
  std::string validate() const;
};

/// The linear relation GPST = gpst_at_zero + slope * boot over the fixes.
struct BootClockFit {
  long double gpst_at_boot_zero_s = 0.0L;
  double slope = 1.0;
  double rms_s = 0.0, max_abs_s = 0.0;  ///< residuals of the fixes kept in the fit
  std::size_t fixes = 0, excluded = 0;  ///< excluded: residual beyond kBootFitOutlierS at first
};
inline constexpr double kBootFitOutlierS = 0.1;
inline constexpr double kImuGapMedianSteps = 3.0;

/// Sign of VZ from a fit of the altitude's rate (central differences of Alt over the fixes)
/// on VZ: d(Alt)/dt = s * VZ.
struct VzSign {
  double s = 0.0, correlation = 0.0;
  std::size_t pairs = 0;
  bool conclusive = false;  ///< |correlation| >= 0.5 over >= 20 pairs
  bool down_positive = true;
};

struct ArduPilotSeries {
  CsvImu imu;  ///< point samples of rate (rad/s) and specific force (m/s^2), body FRD
  GnssSolution gnss;
  BootClockFit clock;
  VzSign vz;
  /// Steps between kept IMU records longer than kImuGapMedianSteps median steps: (boot s of the
  /// record before the gap, gap s). Longer than PlausibilityBounds::kMaxImuStep_s, the dataset
  /// refuses them: the caller cuts them out (--t-start / --t-end).
  std::vector<std::pair<double, double>> imu_gaps_boot_s;
  /// The flight's phases over the whole log (not only the --t-start/--t-end cut), from the
  /// chosen IMU and every GPS fix (find_flight_phases); also in provenance "flight_phases".
  FlightPhases phases;
  /// meta.json "autopilot_estimates": the autopilot EKF's logged bias estimates (null when the
  /// log has none), see autopilot_bias_estimates.
  nlohmann::json autopilot_estimates;
  nlohmann::json provenance;
  std::vector<std::string> notes;
};

/// The bias estimates ArduPilot's EKF logged, for comparison with insid's, in insid's frame (body
/// forward-right-down, ArduPilot's body axes: no rotation) and SI units (rad/s, m/s^2), with the
/// sign of insid's sensor model (measured = true + bias: the EKF subtracts its biases from the
/// IMU's increments). Read (ArduPilot 3.x NavEKF, libraries/DataFlash/DataFlash.cpp
/// Log_Write_EKF; AP_NavEKF.h getGyroBias "rad/sec", getAccelZBias "m/s^2"):
///   EKF1 GX, GY, GZ: gyrX = (int16_t)(100 * degrees(gyroBias.x)), "cd/sec, displayed as deg/sec
///     due to format string": FMT letter c, so the reader's x 0.01 gives deg/s; the one gyro the
///     NavEKF integrates (the primary, normally IMU).
///   EKF2 AZ1bias, AZ2bias: (int8_t)(100 * az1bias): FMT letter b (no scaling), so cm/s^2; the
///     z accelerometer biases of IMU1 and IMU2 (NavEKF's two accelerometer channels: IMU, IMU2).
/// A field whose FMT letter is not the one above (another firmware's layout) is left out with a
/// note rather than read with a guessed scale. For each: the value at the end of the cut window
/// (the last record at or before t_end), and the mean and sample sd over the airborne part of
/// the window (phases). The EKF logs no variance of these states: the sd is how much the
/// estimate wanders in flight, and the logging step (0.01 deg/s, 0.01 m/s^2) bounds the
/// resolution. Returns null when the log has neither EKF1 nor EKF2.
nlohmann::json autopilot_bias_estimates(const DataFlashFile& log, const FlightPhases& phases,
                                        const ArduPilotImportOptions& options,
                                        std::vector<std::string>& notes);

/// When the motors ran, on the boot clock (s), from RCOU (outputs 1-4: fields Ch1..Ch4, or
/// C1..C4; TimeMS filtered like the IMU's by select_increasing_stamps), by motor_runs. nullopt,
/// with a note, when the log has no usable RCOU.
std::optional<MotorRuns> motor_runs_from_rcou(const DataFlashFile& log,
                                              std::vector<std::string>& notes);

/// Reads options.imu and GPS. IMU: TimeMS, GyrX/Y/Z, AccX/Y/Z (sampled values, not increments:
/// assemble_dataset integrates them as point samples by the trapezoid); records whose TimeMS does
/// not increase are dropped and counted. GPS: Status >= min_status; horizontal velocity
/// Spd along GCrs, vertical from VZ with the sign the fit gives (down positive, ArduPilot's
/// convention, when the fit is not conclusive); height Alt (MSL); the motor state
/// (motor_runs_from_rcou) into imu.motors_on_gpst. Throws std::runtime_error
/// naming the file and what is missing.
ArduPilotSeries extract_ardupilot(const DataFlashFile& log, const std::string& where,
                                  const ArduPilotImportOptions& options);

}  // namespace insid::importers
