// From a PX4 ULog to the IMU samples and GNSS solution that assemble_dataset takes (`insid
// import ulog`). Times are PX4's boot clock (the logged `timestamp`, microseconds), common to
// every topic; the GPST of the log start is recorded when the GNSS topic logs `time_utc_usec`.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "import/csv_imu.h"
#include "import/gnss_solution.h"
#include "import/motor_state.h"
#include "import/timestamps.h"
#include "import/ulog.h"

namespace insid::importers {

struct UlogImportOptions {
  /// "" (whichever of vehicle_imu and sensor_combined has more samples), "vehicle_imu" or
  /// "sensor_combined".
  std::string imu_topic;
  int imu_instance = 0;  ///< multi_id of the IMU topic
  int gnss_instance = 0;
  int min_fix_type = 3;  ///< PX4 fix_type: 3 = 3D, 4 = DGPS/RTCM, 5 = RTK float, 6 = RTK fixed
  /// A measured heading: "" (none, the default), "gps" (the GNSS topic's `heading`: PX4's
  /// heading of the body x axis from a dual-antenna receiver, rad, NaN when not available, the
  /// antenna baseline's `heading_offset` already removed by the driver; `heading_accuracy` as
  /// its sd when logged) or "mag" (sensor_mag x/y/z, else vehicle_magnetometer magnetometer_ga;
  /// gauss, body FRD; assemble_dataset levels it and adds --declination-deg).
  std::string heading;
  int mag_instance = 0;  ///< multi_id of the magnetometer topic
  std::string validate() const;
};

struct UlogSeries {
  CsvImu imu;  ///< increments in body FRD (PX4's body frame)
  GnssSolution gnss;
  std::optional<HeadingInput> heading;  ///< options.heading "gps" or "mag"
  nlohmann::json provenance;
  std::vector<std::string> notes;
  /// meta.json "autopilot_estimates" (the schema of the ArduPilot import): the PX4 estimator's
  /// own gyro and accelerometer biases from estimator_sensor_bias instance 0, when logged; null
  /// otherwise.
  nlohmann::json autopilot_estimates;
};

/// The PX4 estimator's bias estimates of a log (estimator_sensor_bias, instance 0): for each of
/// gyro_bias[0..2] (rad/s) and accel_bias[0..2] (m/s^2) in PX4's body frame (FRD, insid's b),
/// the value of the last message, the sd from its *_bias_variance where the layout logs it
/// (PX4 v1.12 and later), and the mean and sample sd over the log. `imu_topic` is the imported
/// IMU topic: the estimator's biases apply to the IMU it fuses, which sensor_combined and
/// vehicle_imu instance 0 carry (PX4's primary), not to other instances. null when the topic is
/// absent. Units and frame from PX4's msg/EstimatorSensorBias.msg.
nlohmann::json px4_bias_estimates(const UlogFile& log, const std::string& imu_topic,
                                  int imu_instance, std::vector<std::string>& notes);

/// When the motors ran, on the log's clock (s), from actuator_outputs output[0..3] (a
/// quadcopter's motors on PX4's main outputs), by motor_runs: the first instance whose outputs
/// are PWM widths (an instance of zeros, e.g. one driving ESCs over a bus, is passed over).
/// nullopt, with notes, when none is.
std::optional<MotorRuns> motor_runs_from_actuator_outputs(const UlogFile& log,
                                                          std::vector<std::string>& notes);

/// Reads the IMU and GNSS topics. vehicle_imu gives delta_angle/delta_velocity increments (kept
/// as they are, at timestamp_sample when logged); sensor_combined gives gyro_rad and
/// accelerometer_m_s2, PX4's means over each sample's integration interval, turned into increments
/// over each row's own interval (mean rate x (t[k] - t[k-1])). GNSS from vehicle_gps_position or
/// sensor_gps, either field layout (integer 1e-7 deg lat/lon and mm heights, or latitude_deg /
/// altitude_ellipsoid_m), ellipsoidal height (MSL only when no ellipsoidal height is logged, with
/// a note), NED velocity; epochs below min_fix_type or with vel_ned_valid false are dropped.
/// Every topic's stamps go through select_increasing_stamps: what it drops is counted in the
/// provenance ("timestamps" of imu, gnss, heading_read; imu.rows_dropped for the assembly) and
/// each jump is a note naming the message and the byte offset of its stamp. The motor schedule
/// (motor_runs_from_actuator_outputs) goes to imu.motors_on_gpst.
/// Throws std::runtime_error naming the file and what is missing: a log without a GNSS topic is
/// refused ("identification needs GNSS velocity") and the message lists the IMU topics it has.
UlogSeries extract_ulog(const UlogFile& log, const std::string& where,
                        const UlogImportOptions& options);

}  // namespace insid::importers
