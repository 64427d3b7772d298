// GNSS solutions read from users' files: RTKLIB solution files (.pos). One epoch per row, times
// on one scale: GPST seconds since 1970-01-01 00:00:00 (no leap seconds; the scale of the
// rtklib-walk IMU log and of `--imu-time gpst-unix`). GPS week/TOW is converted with the GPS
// epoch 1980-01-06 = 315964800 s on that scale.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace insid::importers {

/// An instant: GPST seconds since 1970 in extended precision. A double would quantize today's
/// instants (1.8e9 s) to 2.4e-7 s, a visible error on 6 ms IMU steps; long double keeps 1.2e-10 s
/// on x86-64 (64-bit mantissa). Differences and dataset times (from a whole-second origin) are
/// doubles.
using GpstTime = long double;

/// GPST seconds since 1970 of GPS week 0, TOW 0 (1980-01-06 00:00:00).
inline constexpr GpstTime kGpsEpochGpstUnix_s = 315964800.0L;
inline constexpr double kSecondsPerWeek = 604800.0;

struct GnssEpoch {
  GpstTime t_gpst_unix_s = 0.0L;
  double lat_deg = 0.0, lon_deg = 0.0, h_m = 0.0;  ///< ellipsoidal height
  int quality = 0;  ///< RTKLIB Q: 1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP
  int satellites = 0;
  double sd_n_m = 0.0, sd_e_m = 0.0, sd_u_m = 0.0;
  double v_n_mps = 0.0, v_e_mps = 0.0, v_u_mps = 0.0;
  double sd_vn_mps = 0.0, sd_ve_mps = 0.0, sd_vu_mps = 0.0;
  std::size_t line = 0;  ///< line in the source file
};

struct GnssSolution {
  std::vector<GnssEpoch> epochs;
  std::string format;  ///< "rtklib-pos (date time)" or "rtklib-pos (week tow)"
  /// As CsvImu::source / row_unit: what errors call the file and what GnssEpoch::line counts.
  std::string source;
  std::string row_unit = "line";
};

/// Parses an RTKLIB solution (rnx2rtkp / rtkpost output, "llh" position format): `%`
/// comment lines, the last of which names the columns; time as `yyyy/mm/dd hh:mm:ss.sss` or
/// `week tow` in GPST; latitude(deg) longitude(deg) height(m) Q ns sdn sde sdu sdne sdeu sdun
/// age ratio and, when the solution was written with velocity, vn ve vu (m/s) sdvn sdve sdvu ...
/// Refused, with file, line and column named: another time system (UTC/JST: leap seconds),
/// ECEF/ENU or dms positions, a file without the velocity columns (insid compares velocities;
/// rerun RTKLIB with velocity output, `out-outvel = on`), malformed or non-increasing rows.
/// `where` names the text in messages. Throws std::runtime_error.
GnssSolution parse_rtklib_pos(const std::string& text, const std::string& where);

/// True when the text looks like an RTKLIB solution (a `%` header naming latitude(deg)).
bool looks_like_rtklib_pos(const std::string& text);

}  // namespace insid::importers
