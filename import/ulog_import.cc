#include "import/ulog_import.h"

#include <cmath>
#include <stdexcept>

namespace insid::import {

std::string UlogImportOptions::validate() const {
  if (!imu_topic.empty() && imu_topic != "vehicle_imu" && imu_topic != "sensor_combined")
    return "--imu-topic '" + imu_topic + "': must be vehicle_imu or sensor_combined";
  if (imu_instance < 0 || imu_instance > 255) return "--imu-instance: must be in 0-255";
  if (gnss_instance < 0 || gnss_instance > 255) return "--gnss-instance: must be in 0-255";
  if (min_fix_type < 0 || min_fix_type > 8) return "--min-fix-type: must be in 0-8";
  if (!heading.empty() && heading != "gps" && heading != "mag")
    return "--heading '" + heading +
           "': must be gps (the GNSS topic's dual-antenna heading) or mag (the magnetometer)";
  if (mag_instance < 0 || mag_instance > 255) return "--mag-instance: must be in 0-255";
  return "";
}

UlogSeries extract_ulog(const UlogFile& log, const std::string& where,
                        const UlogImportOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  UlogSeries out;
  nlohmann::json& prov = out.provenance;
  prov["ulog"] = {{"version", log.version()},
                  {"dropouts", log.dropouts()},
                  {"dropout_ms_total", log.dropouts_ms()},
                  {"topics", log.topics_summary()}};
  if (log.dropouts() > 0)
    out.notes.push_back(std::to_string(log.dropouts()) + " logger dropouts, " +
                        std::to_string(std::llround(log.dropouts_ms())) +
                        " ms in all (listed as IMU gaps when they hit the IMU topic)");
  if (!log.truncation().empty()) {
    prov["ulog"]["truncation"] = log.truncation();
    out.notes.push_back(log.truncation());
  }

  // GNSS topic first: without it there is nothing to identify against.
  std::string gnss_topic;
  for (const char* t : {"vehicle_gps_position", "sensor_gps"})
    if (log.instances(t).count(options.gnss_instance)) {
      gnss_topic = t;
      break;
    }
  std::string imu_topic = options.imu_topic;
  if (imu_topic.empty()) {
    // The topic logged at the higher rate (logs often keep vehicle_imu at a few Hz); vehicle_imu
    // (increments, no integration by insid) on a tie.
    const auto count = [&](const char* t) {
      const auto inst = log.instances(t);
      const auto it = inst.find(options.imu_instance);
      return it == inst.end() ? std::size_t{0} : it->second;
    };
    imu_topic =
        count("vehicle_imu") >= count("sensor_combined") ? "vehicle_imu" : "sensor_combined";
  }
  if (gnss_topic.empty()) {
    std::string imu_found;
    for (const char* t : {"vehicle_imu", "sensor_combined"})
      for (const auto& [instance, n] : log.instances(t))
        imu_found += (imu_found.empty() ? "" : ", ") + std::string(t) + " instance " +
                     std::to_string(instance) + " (" + std::to_string(n) + " samples)";
    throw std::runtime_error(
        where + ": no GNSS topic (vehicle_gps_position or sensor_gps, instance " +
        std::to_string(options.gnss_instance) +
        ") with data: insid identifies sensor errors against GNSS velocity, so "
        "this log cannot be imported; IMU found: " +
        (imu_found.empty() ? "none" : imu_found));
  }
  if (!log.instances(imu_topic).count(options.imu_instance))
    throw std::runtime_error(where + ": no data for IMU topic '" + imu_topic + "' instance " +
                             std::to_string(options.imu_instance) +
                             "; topics with data: " + log.topics_summary());

  // IMU.
  CsvImu& imu = out.imu;
  imu.accel_is_increment = true;
  imu.gyro_is_increment = true;
  if (imu_topic == "vehicle_imu") {
    const std::string t_field =
        log.has_field("vehicle_imu", "timestamp_sample") ? "timestamp_sample" : "timestamp";
    const auto rows = log.read("vehicle_imu", options.imu_instance,
                               {t_field, "delta_angle[0]", "delta_angle[1]", "delta_angle[2]",
                                "delta_velocity[0]", "delta_velocity[1]", "delta_velocity[2]"});
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const auto& r = rows[k];
      if (!imu.t_gpst_unix_s.empty() && !(r[0] * 1e-6L > imu.t_gpst_unix_s.back()))
        continue;  // repeated stamp
      imu.t_gpst_unix_s.push_back(static_cast<GpstTime>(r[0]) * 1e-6L);
      imu.gyro_b.emplace_back(r[1], r[2], r[3]);
      imu.accel_b.emplace_back(r[4], r[5], r[6]);
      imu.line.push_back(k + 1);
    }
    prov["imu"]["source"] = "vehicle_imu instance " + std::to_string(options.imu_instance) +
                            ": delta_angle, delta_velocity (increments) at " + t_field;
  } else {
    const auto rows =
        log.read("sensor_combined", options.imu_instance,
                 {"timestamp", "gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]", "accelerometer_m_s2[0]",
                  "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"});
    for (std::size_t k = 1; k < rows.size(); ++k) {
      const auto& r = rows[k];
      const GpstTime t = static_cast<GpstTime>(r[0]) * 1e-6L;
      const GpstTime t_prev = imu.t_gpst_unix_s.empty() ? static_cast<GpstTime>(rows[0][0]) * 1e-6L
                                                        : imu.t_gpst_unix_s.back();
      if (!(t > t_prev)) continue;  // repeated stamp
      const double dt = static_cast<double>(t - t_prev);
      imu.t_gpst_unix_s.push_back(t);
      imu.gyro_b.emplace_back(r[1] * dt, r[2] * dt, r[3] * dt);
      imu.accel_b.emplace_back(r[4] * dt, r[5] * dt, r[6] * dt);
      imu.line.push_back(k + 1);
    }
    prov["imu"]["source"] = "sensor_combined instance " + std::to_string(options.imu_instance) +
                            ": gyro_rad and accelerometer_m_s2 (interval means) x each row's own "
                            "interval";
  }
  if (imu.t_gpst_unix_s.size() < 3)
    throw std::runtime_error(where + ": IMU topic '" + imu_topic + "' has fewer than 3 samples");
  prov["imu"]["axes"] = "PX4 body frame, forward-right-down (no mounting applied)";

  // GNSS, either field layout.
  const bool degrees = log.has_field(gnss_topic, "latitude_deg");
  const bool has_ellipsoid =
      log.has_field(gnss_topic, degrees ? "altitude_ellipsoid_m" : "alt_ellipsoid");
  const std::string height_field = degrees
                                       ? (has_ellipsoid ? "altitude_ellipsoid_m" : "altitude_msl_m")
                                       : (has_ellipsoid ? "alt_ellipsoid" : "alt");
  std::vector<std::string> fields = {"timestamp",
                                     degrees ? "latitude_deg" : "lat",
                                     degrees ? "longitude_deg" : "lon",
                                     height_field,
                                     "vel_n_m_s",
                                     "vel_e_m_s",
                                     "vel_d_m_s",
                                     "fix_type"};
  const bool has_valid = log.has_field(gnss_topic, "vel_ned_valid");
  if (has_valid) fields.push_back("vel_ned_valid");
  const bool has_sats = log.has_field(gnss_topic, "satellites_used");
  if (has_sats) fields.push_back("satellites_used");
  const auto rows = log.read(gnss_topic, options.gnss_instance, fields);
  const double angle_scale = degrees ? 1.0 : 1e-7;
  const double height_scale = degrees ? 1.0 : 1e-3;
  std::size_t low_fix = 0, invalid_velocity = 0, repeated = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& r = rows[k];
    if (r[7] < options.min_fix_type) {
      ++low_fix;
      continue;
    }
    if (has_valid && r[8] == 0.0) {
      ++invalid_velocity;
      continue;
    }
    GnssEpoch e;
    e.t_gpst_unix_s = static_cast<GpstTime>(r[0]) * 1e-6L;
    if (!out.gnss.epochs.empty() && !(e.t_gpst_unix_s > out.gnss.epochs.back().t_gpst_unix_s)) {
      ++repeated;
      continue;
    }
    e.lat_deg = r[1] * angle_scale;
    e.lon_deg = r[2] * angle_scale;
    e.h_m = r[3] * height_scale;
    e.v_n_mps = r[4], e.v_e_mps = r[5], e.v_u_mps = -r[6];
    e.quality = 1;  // accepted here (fix type), kept by assemble_dataset
    e.satellites = has_sats ? static_cast<int>(r.back()) : 0;
    e.line = k + 1;
    out.gnss.epochs.push_back(e);
  }
  out.gnss.format =
      "ulog " + gnss_topic + (degrees ? " (latitude_deg layout)" : " (1e-7 deg integer layout)");
  prov["gnss"]["source"] = gnss_topic + " instance " + std::to_string(options.gnss_instance);
  prov["gnss"]["height"] = has_ellipsoid
                               ? "ellipsoidal (" + height_field + ")"
                               : "MSL (" + height_field + "): no ellipsoidal height logged";
  prov["gnss"]["dropped"] = {{"fix_type_below_" + std::to_string(options.min_fix_type), low_fix},
                             {"vel_ned_valid_false", invalid_velocity},
                             {"repeated_timestamp", repeated}};
  if (!has_ellipsoid)
    out.notes.push_back(
        "GNSS height is MSL (" + height_field +
        "): the log has no ellipsoidal height; heights only enter as the vertical reference");
  if (low_fix + invalid_velocity > 0)
    out.notes.push_back("dropped " + std::to_string(low_fix) + " GNSS epochs with fix_type below " +
                        std::to_string(options.min_fix_type) + " and " +
                        std::to_string(invalid_velocity) + " with vel_ned_valid false");
  if (out.gnss.epochs.size() < 2)
    throw std::runtime_error(where + ": " + gnss_topic + " has " +
                             std::to_string(out.gnss.epochs.size()) +
                             " epochs with fix_type >= " + std::to_string(options.min_fix_type) +
                             " (of " + std::to_string(rows.size()) + "); need at least 2");

  if (options.heading == "gps") {
    // PX4 (SensorGps.msg): "heading: heading angle of XYZ body frame rel to NED. Set to NaN if
    // not available and updated (used for dual antenna GPS), (rad, [-PI, PI])"; heading_offset
    // is the antenna baseline's yaw in the body frame, already taken out by the driver.
    if (!log.has_field(gnss_topic, "heading"))
      throw std::runtime_error(where + ": --heading gps: " + gnss_topic +
                               " has no field 'heading' in this log's format (an older PX4)");
    const bool has_accuracy = log.has_field(gnss_topic, "heading_accuracy");
    std::vector<std::string> hf = {"timestamp", "heading"};
    if (has_accuracy) hf.push_back("heading_accuracy");
    const auto hrows = log.read(gnss_topic, options.gnss_instance, hf);
    HeadingInput h;
    h.source = HeadingSourceKind::kDualAntenna;
    h.origin = gnss_topic + " instance " + std::to_string(options.gnss_instance) +
               ": heading (rad, body x from true north)" +
               (has_accuracy ? ", heading_accuracy as sd" : "");
    std::size_t nan = 0;
    for (std::size_t k = 0; k < hrows.size(); ++k) {
      const auto& r = hrows[k];
      if (!std::isfinite(r[1])) {
        ++nan;
        continue;
      }
      if (!(std::fabs(r[1]) <= 2.0 * 3.14159265358979323846))
        throw std::runtime_error(where + ": " + gnss_topic + " message " + std::to_string(k + 1) +
                                 ", field heading: " + std::to_string(r[1]) +
                                 " rad is not an angle within +-2 pi");
      const GpstTime t = static_cast<GpstTime>(r[0]) * 1e-6L;
      if (!h.t_gpst_unix_s.empty() && !(t > h.t_gpst_unix_s.back())) continue;
      h.t_gpst_unix_s.push_back(t);
      h.yaw_rad.push_back(r[1]);
      const bool sd_ok =
          has_accuracy && std::isfinite(r[2]) && r[2] > 0.0 && r[2] <= 3.14159265358979323846;
      h.sd_rad.push_back(sd_ok ? std::optional<double>(r[2]) : std::nullopt);
      h.line.push_back(k + 1);
    }
    prov["heading_read"] = {{"topic", gnss_topic},
                            {"messages", hrows.size()},
                            {"nan", nan},
                            {"kept", h.t_gpst_unix_s.size()}};
    if (h.t_gpst_unix_s.empty())
      throw std::runtime_error(
          where + ": --heading gps: " + gnss_topic + " logs 'heading' but it is NaN in all " +
          std::to_string(hrows.size()) +
          " messages: the receiver gives no dual-antenna heading (import without --heading, "
          "or with --heading mag)");
    out.heading = std::move(h);
  } else if (options.heading == "mag") {
    std::string topic;
    std::vector<std::string> mf;
    if (log.instances("sensor_mag").count(options.mag_instance) &&
        log.has_field("sensor_mag", "x")) {
      topic = "sensor_mag";
      mf = {"timestamp", "x", "y", "z"};
    } else if (log.instances("vehicle_magnetometer").count(options.mag_instance) &&
               log.has_field("vehicle_magnetometer", "magnetometer_ga[0]")) {
      topic = "vehicle_magnetometer";
      mf = {"timestamp", "magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]"};
    }
    if (topic.empty())
      throw std::runtime_error(where +
                               ": --heading mag: no magnetometer data (sensor_mag x/y/z "
                               "or vehicle_magnetometer magnetometer_ga, instance " +
                               std::to_string(options.mag_instance) +
                               "); topics with data: " + log.topics_summary());
    const auto mrows = log.read(topic, options.mag_instance, mf);
    HeadingInput h;
    h.source = HeadingSourceKind::kMagnetometer;
    h.origin = topic + " instance " + std::to_string(options.mag_instance) + ": " +
               (topic == "sensor_mag" ? "x, y, z" : "magnetometer_ga") + " (gauss, body FRD)";
    for (std::size_t k = 0; k < mrows.size(); ++k) {
      const auto& r = mrows[k];
      const GpstTime t = static_cast<GpstTime>(r[0]) * 1e-6L;
      if (!(std::isfinite(r[1]) && std::isfinite(r[2]) && std::isfinite(r[3]))) continue;
      if (!h.t_gpst_unix_s.empty() && !(t > h.t_gpst_unix_s.back())) continue;
      h.t_gpst_unix_s.push_back(t);
      h.mag_b.emplace_back(r[1], r[2], r[3]);
      h.line.push_back(k + 1);
    }
    prov["heading_read"] = {
        {"topic", topic}, {"messages", mrows.size()}, {"kept", h.t_gpst_unix_s.size()}};
    out.heading = std::move(h);
  }
  return out;
}

}  // namespace insid::import
