// From a PX4 ULog to the IMU samples and GNSS solution that assemble_dataset takes (`insid
// import ulog`). Times are PX4's boot clock (the logged `timestamp`, microseconds), common to
// every topic; the GPST of the log start is recorded when the GNSS topic logs `time_utc_usec`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "import/csv_imu.h"
#include "import/gnss_solution.h"
#include "import/ulog.h"

namespace insid::import {

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
};

/// Reads the IMU and GNSS topics. vehicle_imu gives delta_angle/delta_velocity increments (kept
/// as they are, at timestamp_sample when logged); sensor_combined gives gyro_rad and
/// accelerometer_m_s2, PX4's means over each sample's integration interval, turned into increments
/// over each row's own interval (mean rate x (t[k] - t[k-1])). GNSS from vehicle_gps_position or
/// sensor_gps, either field layout (integer 1e-7 deg lat/lon and mm heights, or latitude_deg /
/// altitude_ellipsoid_m), ellipsoidal height (MSL only when no ellipsoidal height is logged, with
/// a note), NED velocity; epochs below min_fix_type or with vel_ned_valid false are dropped.
/// Throws std::runtime_error naming the file and what is missing: a log without a GNSS topic is
/// refused ("identification needs GNSS velocity") and the message lists the IMU topics it has.
UlogSeries extract_ulog(const UlogFile& log, const std::string& where,
                        const UlogImportOptions& options);

}  // namespace insid::import
