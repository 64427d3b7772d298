#include "import/csv_imu.h"

#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>

#include <Eigen/Geometry>

#include "import/gnss_solution.h"
#include "import/text_lines.h"
#include "model/units.h"

namespace insid::importers {
namespace {

constexpr std::array<const char*, 7> kRoles = {"t", "ax", "ay", "az", "gx", "gy", "gz"};
constexpr std::array<const char*, 5> kOptionalRoles = {"hdg", "hdg_sd", "mx", "my", "mz"};

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::size_t b = 0;
  for (;;) {
    const std::size_t e = text.find(sep, b);
    out.push_back(text.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (e == std::string::npos) return out;
    b = e + 1;
  }
}

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return std::string(s);
}

bool parse_double(std::string_view s, double& v) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && end == s.data() + s.size();
}

// Passive elementary rotations (frame rotations, not vector rotations: rx(a) maps a vector's
// coordinates in a frame into the frame turned by a about x).
Eigen::Matrix3d rx(double a) {
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a);
  return m;
}
Eigen::Matrix3d ry(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), 0, -std::sin(a), 0, 1, 0, std::sin(a), 0, std::cos(a);
  return m;
}
Eigen::Matrix3d rz(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a), 0, 0, 0, 1;
  return m;
}

}  // namespace

Eigen::Matrix3d mounting_matrix(const Eigen::Vector3d& rpy_deg) {
  return rx(rpy_deg.x() * kDegToRad) * ry(rpy_deg.y() * kDegToRad) * rz(rpy_deg.z() * kDegToRad);
}

std::vector<std::string> CsvImuSpec::parse_columns(const std::string& text) {
  std::vector<std::string> roles;
  for (const std::string& r : split(text, ',')) {
    const std::string role = trim(r);
    bool known = role == "-";
    for (const char* k : kRoles) known = known || role == k;
    for (const char* k : kOptionalRoles) known = known || role == k;
    if (!known)
      throw std::invalid_argument("--columns: unknown role '" + role +
                                  "' (allowed: t, ax, ay, az, gx, gy, gz, - to ignore a column; "
                                  "optional: hdg, hdg_sd, mx, my, mz)");
    roles.push_back(role);
  }
  return roles;
}

void CsvImuSpec::parse_units(const std::string& text) {
  const std::vector<std::string> units = split(text, ',');
  if (units.size() != 3)
    throw std::invalid_argument("--units: expected TIME,ACCEL,GYRO (e.g. s,g,rad/s), got '" + text +
                                "'");
  time_unit = trim(units[0]);
  accel_unit = trim(units[1]);
  gyro_unit = trim(units[2]);
  if (const std::string e = validate(); !e.empty()) throw std::invalid_argument(e);
}

std::string CsvImuSpec::validate() const {
  std::map<std::string, int> count;
  for (const std::string& c : columns) ++count[c];
  for (const char* role : kRoles)
    if (count[role] != 1)
      return std::string("--columns: role '") + role + "' must appear exactly once, got " +
             std::to_string(count[role]) + " (roles: t, ax, ay, az, gx, gy, gz, -)";
  for (const char* role : kOptionalRoles)
    if (count[role] > 1)
      return std::string("--columns: role '") + role + "' may appear at most once, got " +
             std::to_string(count[role]);
  if (count["hdg_sd"] && !count["hdg"])
    return "--columns: hdg_sd (the heading's sd) needs the heading column hdg";
  const int mag = count["mx"] + count["my"] + count["mz"];
  if (mag != 0 && mag != 3) return "--columns: a magnetometer needs all three of mx, my, mz";
  if (mag && count["hdg"])
    return "--columns: one heading source per dataset: hdg (dual antenna) or mx, my, mz "
           "(magnetometer), not both";
  if (time_unit != "s" && time_unit != "ms" && time_unit != "us")
    return "--units: time unit '" + time_unit + "' is not s, ms or us";
  if (accel_unit != "g" && accel_unit != "g-local" && accel_unit != "m/s^2" && accel_unit != "m/s")
    return "--units: accelerometer unit '" + accel_unit +
           "' is not g (9.80665 m/s^2), g-local (local normal gravity), m/s^2 or m/s (increments)";
  if (gyro_unit != "rad/s" && gyro_unit != "deg/s" && gyro_unit != "rad" && gyro_unit != "deg")
    return "--units: gyro unit '" + gyro_unit + "' is not rad/s, deg/s, rad or deg (increments)";
  if (time_scale != "gpst-unix" && time_scale != "gps-sow" && time_scale != "relative")
    return "--imu-time '" + time_scale +
           "': must be gpst-unix, gps-sow or relative (with --imu-time-offset-s, the GPS time of "
           "week at the logger's zero)";
  if (rate_samples != "point" && rate_samples != "interval-mean")
    return "--rate-samples '" + rate_samples +
           "': must be point (the rate at each stamp) or interval-mean (the mean over the step "
           "each row closes)";
  if (gps_week && (*gps_week < 0 || *gps_week > 100000))
    return "--gps-week " + std::to_string(*gps_week) + ": must be a GPS week number >= 0";
  if (time_scale == "relative") {
    if (!std::isfinite(time_offset_s) || time_offset_s < 0.0 || time_offset_s >= 604800.0)
      return "--imu-time-offset-s: with --imu-time relative it is the GPS time of week at the "
             "logger's zero, in [0, 604800) s";
  } else if (!std::isfinite(time_offset_s) || std::fabs(time_offset_s) > 86400.0) {
    return "--imu-time-offset-s: must be a finite number of seconds within +-86400";
  }
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(mounting_rpy_deg[k]) || std::fabs(mounting_rpy_deg[k]) > 360.0)
      return "--mounting-rpy-deg: each angle must be finite, within +-360 deg";
  return "";
}

CsvImu read_csv_imu(const std::string& text, const std::string& where, const CsvImuSpec& spec,
                    std::optional<int> gnss_week) {
  if (const std::string e = spec.validate(); !e.empty()) throw std::invalid_argument(e);
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < spec.columns.size(); ++i)
    if (spec.columns[i] != "-") index[spec.columns[i]] = i;
  const double t_scale = spec.time_unit == "s" ? 1.0 : spec.time_unit == "ms" ? 1e-3 : 1e-6;
  const double g_scale = spec.gyro_unit == "deg/s" || spec.gyro_unit == "deg" ? kDegToRad : 1.0;
  const double a_scale =
      spec.accel_unit == "g" ? kStandardGravity_mps2 : 1.0;  // g-local: applied later
  GpstTime t_base = 0.0L;
  if (spec.time_scale == "gps-sow" || spec.time_scale == "relative") {
    const std::optional<int> week = spec.gps_week ? spec.gps_week : gnss_week;
    if (!week)
      throw std::invalid_argument("--imu-time " + spec.time_scale +
                                  ": give --gps-week (the GNSS file does not give a week)");
    t_base = kGpsEpochGpstUnix_s + *week * kSecondsPerWeek;
  }
  const Eigen::Matrix3d C_s_b = mounting_matrix(spec.mounting_rpy_deg);

  CsvImu out;
  out.origin = where;
  if (index.count("hdg")) {
    out.heading.emplace();
    out.heading->origin =
        "CSV column " + std::to_string(index.at("hdg") + 1) + " (hdg, deg from true north)" +
        (index.count("hdg_sd") ? ", sd in column " + std::to_string(index.at("hdg_sd") + 1)
                               : std::string());
  } else if (index.count("mx")) {
    out.heading.emplace();
    out.heading->source = HeadingSourceKind::kMagnetometer;
    out.heading->origin = "CSV columns " + std::to_string(index.at("mx") + 1) + ", " +
                          std::to_string(index.at("my") + 1) + ", " +
                          std::to_string(index.at("mz") + 1) +
                          " (mx, my, mz; sensor axes, mounting applied)";
  }
  out.accel_in_g_local = spec.accel_unit == "g-local";
  out.accel_is_increment = spec.accel_is_increment();
  out.gyro_is_increment = spec.gyro_is_increment();
  out.rates_are_interval_means = spec.rate_samples == "interval-mean";
  TextLines lines(text);
  std::string_view line_view;
  std::size_t line_no = 0;
  while (lines.next(&line_view, &line_no)) {
    const std::string line(line_view);
    if (trim(line).empty()) continue;
    const std::vector<std::string> fields = split(line, ',');
    double first = 0.0;
    if (out.line.empty() && line_no == 1 && !parse_double(trim(fields[0]), first))
      continue;  // header
    const std::string at = where + " line " + std::to_string(line_no);
    if (fields.size() != spec.columns.size())
      throw std::runtime_error(at + ": " + std::to_string(fields.size()) +
                               " fields, --columns names " + std::to_string(spec.columns.size()));
    const auto value = [&](const char* role) {
      const std::size_t c = index.at(role);
      double v = 0.0;
      const std::string f = trim(fields[c]);
      if (!parse_double(f, v) || !std::isfinite(v))
        throw std::runtime_error(at + ", column " + std::to_string(c + 1) + " (" + role +
                                 "): expected a finite number, got '" + f + "'");
      return v;
    };
    (void)value("t");  // checked as a double, read in extended precision:
    GpstTime t_raw = 0.0L;
    {
      const std::string f = trim(fields[index.at("t")]);
      std::from_chars(f.data(), f.data() + f.size(), t_raw);
    }
    const GpstTime t = t_base + t_raw * static_cast<GpstTime>(t_scale) + spec.time_offset_s;
    if (!out.t_gpst_unix_s.empty() && !(t > out.t_gpst_unix_s.back()))
      throw std::runtime_error(at + ", column " + std::to_string(index.at("t") + 1) +
                               " (t): time does not increase after line " +
                               std::to_string(out.line.back()) +
                               " (IMU rows must be in time order)");
    out.t_gpst_unix_s.push_back(t);
    out.accel_b.push_back(C_s_b * Eigen::Vector3d(value("ax"), value("ay"), value("az")) * a_scale);
    out.gyro_b.push_back(C_s_b * Eigen::Vector3d(value("gx"), value("gy"), value("gz")) * g_scale);
    out.line.push_back(line_no);
    if (out.heading) {
      // An empty or nan heading field: no sample on this row (receivers log fewer headings).
      HeadingInput& h = *out.heading;
      if (h.source == HeadingSourceKind::kMagnetometer) {
        h.t_gpst_unix_s.push_back(t);
        h.mag_b.push_back(C_s_b * Eigen::Vector3d(value("mx"), value("my"), value("mz")));
        h.line.push_back(line_no);
      } else if (const std::string f = trim(fields[index.at("hdg")]);
                 !f.empty() && f != "nan" && f != "NaN") {
        const double deg = value("hdg");
        if (!(std::fabs(deg) <= 360.0))
          throw std::runtime_error(at + ", column " + std::to_string(index.at("hdg") + 1) +
                                   " (hdg): heading " + f + " deg is not within [-360, 360]");
        std::optional<double> sd;
        if (index.count("hdg_sd")) {
          const double sd_deg = value("hdg_sd");
          if (!(sd_deg > 0.0 && sd_deg <= 180.0))
            throw std::runtime_error(at + ", column " + std::to_string(index.at("hdg_sd") + 1) +
                                     " (hdg_sd): heading sd " + trim(fields[index.at("hdg_sd")]) +
                                     " deg must lie in (0, 180]");
          sd = sd_deg * kDegToRad;
        }
        h.t_gpst_unix_s.push_back(t);
        h.yaw_rad.push_back(deg * kDegToRad);
        h.sd_rad.push_back(sd);
        h.line.push_back(line_no);
      }
    }
  }
  if (out.line.size() < 3)
    throw std::runtime_error(where + ": " + std::to_string(out.line.size()) +
                             " IMU rows; need at least 3");
  return out;
}

}  // namespace insid::importers
