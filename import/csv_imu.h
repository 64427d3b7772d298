// IMU samples from a logger's CSV file, read with a user's mapping spec (`insid import csv`):
// which column holds what, the units, the time scale, and the sensor-to-body mounting.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "data/dataset.h"
#include "import/gnss_solution.h"

namespace insid::importers {

/// How to read an IMU CSV file. Parse the command-line strings with parse_columns/parse_units,
/// then validate() (called by read_csv_imu).
struct CsvImuSpec {
  /// One role per CSV column, in order: t, ax, ay, az, gx, gy, gz, or "-" (ignored). Each of
  /// the seven roles exactly once. Optional, at most once each, one heading source only:
  /// hdg (a dual-antenna heading of the body x axis, deg clockwise from true north; an empty or
  /// nan field: no sample on that row) with optional hdg_sd (its sd, deg); or mx, my, mz (a
  /// magnetometer in sensor axes, any unit: only the direction is used).
  std::vector<std::string> columns;
  std::string time_unit = "s";       ///< s | ms | us
  std::string accel_unit = "m/s^2";  ///< g (9.80665 m/s^2) | g-local (local normal gravity) |
                                     ///< m/s^2 | m/s (velocity increments)
  std::string gyro_unit = "rad/s";   ///< rad/s | deg/s | rad | deg (the last two: increments)
  /// gpst-unix: GPST seconds since 1970 (no leap seconds); gps-sow: GPST seconds of week (with
  /// gps_week, or the week of the GNSS file's first epoch); relative: seconds from the logger's
  /// own origin, placed on GPST by time_offset_s = the GPS time of week at the logger's zero
  /// (same week rule as gps-sow).
  std::string time_scale = "gpst-unix";
  std::optional<int> gps_week;
  /// Added to every IMU time: a known IMU clock offset (within +-86400 s), or for `relative` the
  /// GPS time of week of the logger's zero, in [0, 604800) s.
  double time_offset_s = 0.0;
  /// What a rate row holds: "point" (the rate at the row's stamp, e.g. a low-passed sensor
  /// output; integrated by the trapezoid over the row's own step) or "interval-mean" (the mean
  /// over the interval the row closes, e.g. PX4's sensor_combined; times the row's own step).
  std::string rate_samples = "point";
  /// v_b = Rx(R) Ry(P) Rz(Y) v_s with the passive elementary rotations (the matrix roll, pitch,
  /// yaw give for C_n^b): a vector measured in sensor axes expressed in body FRD axes.
  Eigen::Vector3d mounting_rpy_deg = Eigen::Vector3d::Zero();

  /// "t,ax,ay,az,gx,gy,gz,-,-" -> columns. Throws std::invalid_argument naming a bad role.
  static std::vector<std::string> parse_columns(const std::string& text);
  /// "s,g,rad/s" (time, accelerometer, gyro) -> the three units. Throws naming a bad unit.
  void parse_units(const std::string& text);
  /// "" or the first problem, naming the field and what is allowed.
  std::string validate() const;
  bool accel_is_increment() const { return accel_unit == "m/s"; }
  bool gyro_is_increment() const { return gyro_unit == "rad" || gyro_unit == "deg"; }
};

/// A heading read with the IMU (CSV hdg / mx,my,mz columns; a ULog's GNSS heading or
/// magnetometer), turned into heading.csv by assemble_dataset.
struct HeadingInput {
  HeadingSourceKind source = HeadingSourceKind::kDualAntenna;
  std::vector<GpstTime> t_gpst_unix_s;
  std::vector<double> yaw_rad;                ///< dual antenna: body x, clockwise from true north
  std::vector<std::optional<double>> sd_rad;  ///< dual antenna: the sample's sd when given
  std::vector<Eigen::Vector3d> mag_b;         ///< magnetometer: field in body FRD (any unit)
  std::vector<std::size_t> line;              ///< source line / message of each sample
  std::string origin;                         ///< for the provenance, e.g. "CSV column 8 (hdg)"
};

/// C_s^b of the mounting: v_b = C_s_b * v_s.
Eigen::Matrix3d mounting_matrix(const Eigen::Vector3d& rpy_deg);

/// Rows of the CSV as read, converted to SI in body axes (mounting applied); time on the GPST
/// seconds-since-1970 scale when the spec's scale is gps-sow (with the week), with the offset.
struct CsvImu {
  std::vector<GpstTime> t_gpst_unix_s;
  std::vector<Eigen::Vector3d> accel_b;  ///< m/s^2 or m/s (increments), per accel_is_increment
  std::vector<Eigen::Vector3d> gyro_b;   ///< rad/s or rad (increments), per gyro_is_increment
  std::vector<std::size_t> line;         ///< source line of each row
  /// Byte offset in the source file of each row's record (binary logs: a ULog data message, a
  /// DataFlash record), for errors that name a row; empty for text files.
  std::vector<std::size_t> byte;
  bool accel_in_g_local = false;  ///< accel_b is in units of local gravity still
  bool accel_is_increment = false;
  bool gyro_is_increment = false;
  bool rates_are_interval_means = false;  ///< spec.rate_samples == "interval-mean"
  std::optional<HeadingInput> heading;    ///< when the spec maps hdg or mx, my, mz
  /// When the motors ran, GPST (an autopilot's motor outputs): assemble_dataset writes them as
  /// meta.json "motors" on the dataset's clock and ends the static window at motor start.
  std::vector<std::pair<GpstTime, GpstTime>> motors_on_gpst;
  std::string motors_source;  ///< how the motor state was read, for meta.json and the notes
  /// Rows (lines, messages) of the source and those the reader did not keep, by reason (e.g.
  /// "timestamp_jump"), for the assembly's provenance and notes; source_rows 0: every row was
  /// kept (the CSV reader keeps every row or refuses the file).
  std::size_t source_rows = 0;
  std::map<std::string, std::size_t> rows_dropped;
  /// Where the rows come from, for messages ("LOG.ulg, sensor_combined"); "" says "the IMU".
  std::string origin;
  /// What `line` counts in `origin` ("line", "message", "record"), for errors that name a row.
  std::string row_unit = "line";
};

/// Reads `path` with `spec` (comma separated; an optional header line is skipped when its
/// first field is not a number; blank lines ignored). `gnss_week` is used for gps-sow when the
/// spec gives none. Throws std::runtime_error naming file, line and column.
CsvImu read_csv_imu(const std::string& text, const std::string& where, const CsvImuSpec& spec,
                    std::optional<int> gnss_week);

}  // namespace insid::importers
