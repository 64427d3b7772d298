// The KF-GINS text layout (i2Nav-WHU/KF-GINS, and the awesome-gins-datasets collection), read and
// written. Fields are separated by commas, spaces or tabs (as KF-GINS's loader splits them).
//   IMU:  GPS seconds of week, dtheta x y z (rad), dvel x y z (m/s); body forward-right-down;
//         each row the increment over the interval ending at its time.
//   GNSS: 7 columns  SOW, latitude (deg), longitude (deg), height (m), std N E D (m)
//         13 columns SOW, lat, lon, h, vN vE vD (m/s), std N E D (m), std vN vE vD (m/s)
//         (KF-GINS reads the position std at columns 8-10 of a 13-column file).
// Heights are taken as ellipsoidal.
#pragma once

#include <optional>
#include <string>

#include "data/dataset.h"
#include "import/csv_imu.h"
#include "import/gnss_solution.h"

namespace insid::importers {

/// IMU rows as increments in body FRD; times on the GPST-since-1970 scale of `gps_week` (week 0
/// when not given: the times then only order the rows). Throws std::runtime_error naming line
/// and column.
CsvImu parse_kf_gins_imu(const std::string& text, const std::string& where,
                         std::optional<int> gps_week);

/// GNSS rows. A 7-column (position-only) file gets velocities by central differences of the
/// positions in local north/east/up, v_k = (p_{k+1} - p_{k-1}) / (t_{k+1} - t_{k-1}) (one-sided at
/// the ends): for white position noise sigma_p the velocity noise is sigma_p / (sqrt(2) dt), and a
/// jerk j adds up to j dt^2 / 6 (1 cm at 1 Hz: 0.7 cm/s; 1 m/s^3 at 1 Hz: 0.17 m/s); the format
/// string says "velocity derived". Every epoch gets quality 1 (the layout has no flag).
GnssSolution parse_kf_gins_gnss(const std::string& text, const std::string& where,
                                std::optional<int> gps_week);

/// True when the text looks like a KF-GINS GNSS file (7 or 13 numeric fields on its first line).
bool looks_like_kf_gins_gnss(const std::string& text);

/// An insid dataset in the KF-GINS layout: imu.txt and the 13-column gnss.txt (positions,
/// velocities NED, and the given standard deviations). Times: the dataset's t_s + sow_offset_s.
/// Numbers are written with 17 significant digits (exact for doubles).
std::string kf_gins_imu_text(const Dataset& dataset, double sow_offset_s);
std::string kf_gins_gnss_text(const Dataset& dataset, double sow_offset_s, double pos_std_m,
                              double vel_std_mps);

}  // namespace insid::importers
