#include "import/ulog_import.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "base/number_text.h"
#include "import/log_damage.h"
#include "model/earth.h"
#include "model/rotation.h"

namespace insid::importers {
namespace {

// select_increasing_stamps on the `t_field` stamps of a topic's messages (`rows`, column 0),
// recorded in `prov` ("timestamps") and, when anything was dropped or jumped, a note.
TimestampSelection select_topic_stamps(const UlogFile& log, const std::string& topic, int instance,
                                       const std::string& t_field,
                                       const std::vector<std::vector<double>>& rows,
                                       nlohmann::json& prov, std::vector<std::string>& notes) {
  std::vector<double> stamps_us;
  stamps_us.reserve(rows.size());
  for (const auto& r : rows) stamps_us.push_back(r[0]);
  TimestampSelection sel =
      select_increasing_stamps(stamps_us, log.field_offsets(topic, instance, t_field));
  record_stamp_selection(sel, stamps_us, topic + " instance " + std::to_string(instance), t_field,
                         prov, notes);
  return sel;
}

}  // namespace

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

namespace {

// The log's own health (format version, logger dropouts, truncation) in the provenance and notes.
void record_log_health(const UlogFile& log, UlogSeries& out) {
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
  record_skipped_damage(log.skip_count(), log.skipped_bytes(), log.skips(), "message", "ulog", prov,
                        out.notes);
  if (!log.damaged_formats().empty()) {
    prov["ulog"]["damaged_formats"] = log.damaged_formats();
    std::string list;
    for (const auto& [name, why] : log.damaged_formats())
      list += (list.empty() ? "" : "; ") + name + " (" + why + ")";
    out.notes.push_back(std::to_string(log.damaged_formats().size()) +
                        " topic formats ('F') cannot be read, their data is not used: " + list);
  }
}

struct UlogTopics {
  std::string gnss;
  std::string imu;
};

// The topics to read: the GNSS topic of options.gnss_instance (vehicle_gps_position, else
// sensor_gps) and the IMU topic (options.imu_topic, else the one logged at the higher rate);
// refuses a log without data for either.
UlogTopics choose_topics(const UlogFile& log, const std::string& where,
                         const UlogImportOptions& options) {
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
        (imu_found.empty() ? "none" : imu_found) + log.damage());
  }
  if (!log.instances(imu_topic).count(options.imu_instance))
    throw std::runtime_error(where + ": no data for IMU topic '" + imu_topic + "' instance " +
                             std::to_string(options.imu_instance) +
                             "; topics with data: " + log.topics_summary() + log.damage());
  return {gnss_topic, imu_topic};
}

// out.imu from `imu_topic`: vehicle_imu's increments as logged, or sensor_combined's interval
// means times each row's own interval; refuses fewer than 3 samples with consistent timestamps.
void read_imu(const UlogFile& log, const std::string& where, const UlogImportOptions& options,
              const std::string& imu_topic, UlogSeries& out) {
  nlohmann::json& prov = out.provenance;
  CsvImu& imu = out.imu;
  imu.origin = where + ", " + imu_topic + " instance " + std::to_string(options.imu_instance);
  imu.row_unit = "message";
  imu.accel_is_increment = true;
  imu.gyro_is_increment = true;
  const bool increments = imu_topic == "vehicle_imu";
  const std::string t_field = increments && log.has_field("vehicle_imu", "timestamp_sample")
                                  ? "timestamp_sample"
                                  : "timestamp";
  const auto rows =
      increments
          ? log.read("vehicle_imu", options.imu_instance,
                     {t_field, "delta_angle[0]", "delta_angle[1]", "delta_angle[2]",
                      "delta_velocity[0]", "delta_velocity[1]", "delta_velocity[2]"})
          : log.read("sensor_combined", options.imu_instance,
                     {t_field, "gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]", "accelerometer_m_s2[0]",
                      "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"});
  const TimestampSelection imu_sel = select_topic_stamps(log, imu_topic, options.imu_instance,
                                                         t_field, rows, prov["imu"], out.notes);
  const std::vector<std::size_t> imu_bytes = log.message_offsets(imu_topic, options.imu_instance);
  imu.source_rows = rows.size();
  imu.rows_dropped["repeated_timestamp"] = imu_sel.repeated;
  imu.rows_dropped["timestamp_jump"] = imu_sel.dropped_by_jumps;
  if (increments) {
    for (const std::size_t k : imu_sel.kept) {
      const auto& r = rows[k];
      imu.t_gpst_unix_s.push_back(static_cast<GpstTime>(r[0]) * 1e-6L);
      imu.gyro_b.emplace_back(r[1], r[2], r[3]);
      imu.accel_b.emplace_back(r[4], r[5], r[6]);
      imu.line.push_back(k + 1);
      imu.byte.push_back(imu_bytes.at(k));
    }
    prov["imu"]["source"] = "vehicle_imu instance " + std::to_string(options.imu_instance) +
                            ": delta_angle, delta_velocity (increments) at " + t_field;
  } else {
    // The first kept message only opens the first interval.
    if (!imu_sel.kept.empty()) imu.rows_dropped["interval_start"] = 1;
    for (std::size_t i = 1; i < imu_sel.kept.size(); ++i) {
      const auto& r = rows[imu_sel.kept[i]];
      const GpstTime t = static_cast<GpstTime>(r[0]) * 1e-6L;
      const GpstTime t_prev = static_cast<GpstTime>(rows[imu_sel.kept[i - 1]][0]) * 1e-6L;
      const double dt = static_cast<double>(t - t_prev);
      imu.t_gpst_unix_s.push_back(t);
      imu.gyro_b.emplace_back(r[1] * dt, r[2] * dt, r[3] * dt);
      imu.accel_b.emplace_back(r[4] * dt, r[5] * dt, r[6] * dt);
      imu.line.push_back(imu_sel.kept[i] + 1);
      imu.byte.push_back(imu_bytes.at(imu_sel.kept[i]));
    }
    prov["imu"]["source"] = "sensor_combined instance " + std::to_string(options.imu_instance) +
                            ": gyro_rad and accelerometer_m_s2 (interval means) x each row's own "
                            "interval";
  }
  if (imu.t_gpst_unix_s.size() < 3)
    throw std::runtime_error(
        where + ": IMU topic '" + imu_topic + "' has " + std::to_string(imu.t_gpst_unix_s.size()) +
        " samples with consistent timestamps (of " + std::to_string(rows.size()) +
        " messages: " + std::to_string(imu_sel.repeated) + " repeated, " +
        std::to_string(imu_sel.dropped_by_jumps) + " dropped in timestamp jumps); need at least 3");
  prov["imu"]["axes"] = "PX4 body frame, forward-right-down (no mounting applied)";
}

// out.gnss from `gnss_topic` (either field layout: latitude_deg or 1e-7 deg integers), epochs
// below options.min_fix_type or with vel_ned_valid false dropped and counted; refuses fewer
// than 2 usable epochs.
void read_gnss(const UlogFile& log, const std::string& where, const UlogImportOptions& options,
               const std::string& gnss_topic, UlogSeries& out) {
  nlohmann::json& prov = out.provenance;
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
  const auto gnss_rows = log.read(gnss_topic, options.gnss_instance, fields);
  const TimestampSelection gnss_sel = select_topic_stamps(
      log, gnss_topic, options.gnss_instance, "timestamp", gnss_rows, prov["gnss"], out.notes);
  const double angle_scale = degrees ? 1.0 : 1e-7;
  const double height_scale = degrees ? 1.0 : 1e-3;
  std::size_t low_fix = 0, invalid_velocity = 0;
  for (const std::size_t k : gnss_sel.kept) {
    const auto& r = gnss_rows[k];
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
    e.lat_deg = r[1] * angle_scale;
    e.lon_deg = r[2] * angle_scale;
    e.h_m = r[3] * height_scale;
    e.v_n_mps = r[4], e.v_e_mps = r[5], e.v_u_mps = -r[6];
    e.quality = 1;  // accepted here (fix type), kept by assemble_dataset
    e.satellites = has_sats ? static_cast<int>(r.back()) : 0;
    e.line = k + 1;
    out.gnss.epochs.push_back(e);
  }
  out.gnss.source =
      where + ", " + gnss_topic + " instance " + std::to_string(options.gnss_instance);
  out.gnss.row_unit = "message";
  out.gnss.format =
      "ulog " + gnss_topic + (degrees ? " (latitude_deg layout)" : " (1e-7 deg integer layout)");
  prov["gnss"]["source"] = gnss_topic + " instance " + std::to_string(options.gnss_instance);
  prov["gnss"]["height"] = has_ellipsoid
                               ? "ellipsoidal (" + height_field + ")"
                               : "MSL (" + height_field + "): no ellipsoidal height logged";
  prov["gnss"]["dropped"] = {{"fix_type_below_" + std::to_string(options.min_fix_type), low_fix},
                             {"vel_ned_valid_false", invalid_velocity},
                             {"repeated_timestamp", gnss_sel.repeated},
                             {"timestamp_jump", gnss_sel.dropped_by_jumps}};
  if (!has_ellipsoid)
    out.notes.push_back(
        "GNSS height is MSL (" + height_field +
        "): the log has no ellipsoidal height; heights only enter as the vertical reference");
  if (low_fix + invalid_velocity > 0)
    out.notes.push_back("dropped " + std::to_string(low_fix) + " GNSS epochs with fix_type below " +
                        std::to_string(options.min_fix_type) + " and " +
                        std::to_string(invalid_velocity) + " with vel_ned_valid false");
  if (out.gnss.epochs.size() < 2)
    throw std::runtime_error(
        where + ": " + gnss_topic + " keeps " + std::to_string(out.gnss.epochs.size()) +
        " usable epochs of " + std::to_string(gnss_rows.size()) + " messages (dropped: " +
        std::to_string(gnss_sel.repeated) + " with a repeated timestamp, " +
        std::to_string(gnss_sel.dropped_by_jumps) + " in timestamp jumps, " +
        std::to_string(low_fix) + " with fix_type below " + std::to_string(options.min_fix_type) +
        ", " + std::to_string(invalid_velocity) + " with vel_ned_valid false); need at least 2");
}

// --heading gps: the GNSS topic's dual-antenna heading (NaN messages skipped and counted).
HeadingInput read_gps_heading(const UlogFile& log, const std::string& where,
                              const UlogImportOptions& options, const std::string& gnss_topic,
                              UlogSeries& out) {
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
  nlohmann::json& hprov = out.provenance["heading_read"];
  const TimestampSelection hsel = select_topic_stamps(log, gnss_topic, options.gnss_instance,
                                                      "timestamp", hrows, hprov, out.notes);
  HeadingInput h;
  h.source = HeadingSourceKind::kDualAntenna;
  h.origin = gnss_topic + " instance " + std::to_string(options.gnss_instance) +
             ": heading (rad, body x from true north)" +
             (has_accuracy ? ", heading_accuracy as sd" : "");
  std::size_t nan = 0;
  for (const std::size_t k : hsel.kept) {
    const auto& r = hrows[k];
    if (!std::isfinite(r[1])) {
      ++nan;
      continue;
    }
    if (!(std::fabs(r[1]) <= 2.0 * 3.14159265358979323846))
      throw std::runtime_error(where + ": " + gnss_topic + " message " + std::to_string(k + 1) +
                               ", field heading: " + std::to_string(r[1]) +
                               " rad is not an angle within +-2 pi");
    h.t_gpst_unix_s.push_back(static_cast<GpstTime>(r[0]) * 1e-6L);
    h.yaw_rad.push_back(r[1]);
    const bool sd_ok =
        has_accuracy && std::isfinite(r[2]) && r[2] > 0.0 && r[2] <= 3.14159265358979323846;
    h.sd_rad.push_back(sd_ok ? std::optional<double>(r[2]) : std::nullopt);
    h.line.push_back(k + 1);
  }
  hprov["topic"] = gnss_topic;
  hprov["messages"] = hrows.size();
  hprov["nan"] = nan;
  hprov["kept"] = h.t_gpst_unix_s.size();
  if (h.t_gpst_unix_s.empty())
    throw std::runtime_error(
        where + ": --heading gps: " + gnss_topic + " logs 'heading' but it is NaN in all " +
        std::to_string(hrows.size()) +
        " messages: the receiver gives no dual-antenna heading (import without --heading, "
        "or with --heading mag)");
  return h;
}

// --heading mag: the magnetometer (sensor_mag, else vehicle_magnetometer) of
// options.mag_instance, in gauss, body FRD (non-finite messages skipped and counted).
HeadingInput read_mag_heading(const UlogFile& log, const std::string& where,
                              const UlogImportOptions& options, UlogSeries& out) {
  std::string topic;
  std::vector<std::string> mf;
  if (log.instances("sensor_mag").count(options.mag_instance) && log.has_field("sensor_mag", "x")) {
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
  nlohmann::json& hprov = out.provenance["heading_read"];
  const TimestampSelection msel =
      select_topic_stamps(log, topic, options.mag_instance, "timestamp", mrows, hprov, out.notes);
  HeadingInput h;
  h.source = HeadingSourceKind::kMagnetometer;
  h.origin = topic + " instance " + std::to_string(options.mag_instance) + ": " +
             (topic == "sensor_mag" ? "x, y, z" : "magnetometer_ga") + " (gauss, body FRD)";
  std::size_t not_finite = 0;
  for (const std::size_t k : msel.kept) {
    const auto& r = mrows[k];
    if (!(std::isfinite(r[1]) && std::isfinite(r[2]) && std::isfinite(r[3]))) {
      ++not_finite;
      continue;
    }
    h.t_gpst_unix_s.push_back(static_cast<GpstTime>(r[0]) * 1e-6L);
    h.mag_b.emplace_back(r[1], r[2], r[3]);
    h.line.push_back(k + 1);
  }
  hprov["topic"] = topic;
  hprov["messages"] = mrows.size();
  hprov["not_finite"] = not_finite;
  hprov["kept"] = h.t_gpst_unix_s.size();
  return h;
}

}  // namespace

UlogSeries extract_ulog(const UlogFile& log, const std::string& where,
                        const UlogImportOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  UlogSeries out;
  record_log_health(log, out);
  const UlogTopics topics = choose_topics(log, where, options);
  read_imu(log, where, options, topics.imu, out);
  read_gnss(log, where, options, topics.gnss, out);
  if (options.heading == "gps")
    out.heading = read_gps_heading(log, where, options, topics.gnss, out);
  else if (options.heading == "mag")
    out.heading = read_mag_heading(log, where, options, out);
  out.autopilot_estimates = px4_bias_estimates(log, topics.imu, options.imu_instance, out.notes);
  if (const std::optional<MotorRuns> motors = motor_runs_from_actuator_outputs(log, out.notes)) {
    for (const auto& [on, off] : motors->on_s)
      out.imu.motors_on_gpst.emplace_back(static_cast<GpstTime>(on), static_cast<GpstTime>(off));
    out.imu.motors_source = motors->source;
    out.provenance["motors_read"] = motors->source;
  }
  return out;
}

std::optional<MotorRuns> motor_runs_from_actuator_outputs(const UlogFile& log,
                                                          std::vector<std::string>& notes) {
  const std::string kTopic = "actuator_outputs";
  std::vector<std::string> fields = {"timestamp"};
  for (int c = 0; c < kMotorChannels; ++c) fields.push_back("output[" + std::to_string(c) + "]");
  std::vector<std::string> why_not;
  for (const auto& [instance, count] : log.instances(kTopic)) {
    if (count < 2) continue;
    const std::vector<std::vector<double>> rows = log.read(kTopic, instance, fields);
    nlohmann::json prov;
    const TimestampSelection sel =
        select_topic_stamps(log, kTopic, instance, "timestamp", rows, prov, notes);
    std::optional<MotorRuns> runs =
        motor_runs(rows, sel.kept, 1e-6,
                   kTopic + " instance " + std::to_string(instance) + " output[0-3]", why_not);
    if (runs) return runs;
  }
  if (why_not.empty()) why_not.push_back("no " + kTopic + ": the motor state is unknown");
  notes.insert(notes.end(), why_not.begin(), why_not.end());
  return std::nullopt;
}

nlohmann::json px4_bias_estimates(const UlogFile& log, const std::string& imu_topic,
                                  int imu_instance, std::vector<std::string>& notes) {
  const std::string topic = "estimator_sensor_bias";
  if (log.instances(topic).count(0) == 0) return nullptr;
  const bool primary = imu_instance == 0;
  nlohmann::json list = nlohmann::json::array();
  std::string summary;
  for (const char* sensor : {"gyro", "accel"}) {
    const bool gyro = sensor[0] == 'g';
    const std::string base = std::string(sensor) + "_bias";
    const bool has_variance = log.has_field(topic, base + "_variance[0]");
    for (int axis = 0; axis < 3; ++axis) {
      const std::string field = base + "[" + std::to_string(axis) + "]";
      if (!log.has_field(topic, field)) continue;
      std::vector<std::string> fields = {"timestamp", field};
      if (has_variance) fields.push_back(base + "_variance[" + std::to_string(axis) + "]");
      const auto rows = log.read(topic, 0, fields);
      double sum = 0, sum2 = 0;
      std::size_t n = 0;
      const std::vector<double>* last = nullptr;
      for (const auto& r : rows) {
        if (!std::isfinite(r[1])) continue;
        sum += r[1], sum2 += r[1] * r[1], ++n;
        last = &r;
      }
      if (last == nullptr) continue;
      const double mean = sum / static_cast<double>(n);
      const double sd =
          n > 1 ? std::sqrt(std::max(0.0, (sum2 - static_cast<double>(n) * mean * mean) /
                                              static_cast<double>(n - 1)))
                : 0.0;
      const double end = (*last)[1];
      const double display = gyro ? kRadToDeg : 1e3 / kStandardGravity_mps2;  // deg/s or mg
      const char xyz = static_cast<char>('x' + axis);
      nlohmann::json e = {
          {"effect", std::string(sensor) + "_bias_" + xyz},
          {"source", topic + "." + field},
          {"imu", "estimator's IMU"},
          {"applies_to_imported_imu", primary},
          {"logged_as", "float32 " + std::string(gyro ? "rad/s" : "m/s^2") + ", body FRD"},
          {"si_unit", gyro ? "rad/s" : "m/s^2"},
          {"end_log_s", ((*last)[0] - static_cast<double>(log.start_timestamp_us())) * 1e-6},
          {"end_si", end},
          {"sd_si", has_variance && std::isfinite((*last)[2]) && (*last)[2] >= 0
                        ? nlohmann::json(std::sqrt((*last)[2]))
                        : nlohmann::json(nullptr)},
          {"messages", n},
          {"log_mean_si", mean},
          {"log_sd_si", sd},
          {"airborne_mean_si", nullptr},
          {"airborne_sd_si", nullptr},
          {"resolution_si", 0.0},
          {"display_unit", gyro ? "deg/s" : "mg"},
          {"end_display", end * display}};
      summary +=
          (summary.empty() ? "" : "; ") + e["effect"].get<std::string>() + " " +
          number_text(end * display, 3) +
          (e["sd_si"].is_null() ? std::string()
                                : " +- " + number_text(e["sd_si"].get<double>() * display, 2)) +
          " " + (gyro ? "deg/s" : "mg");
      list.push_back(e);
    }
  }
  if (list.empty()) return nullptr;
  notes.push_back("autopilot estimator bias estimates (meta.json autopilot_estimates; the last " +
                  topic + " message" + std::string(primary ? "" : ", for the primary IMU only") +
                  "): " + summary);
  return {{"autopilot", "PX4 estimator (" + topic + ", instance 0)"},
          {"frame", "body forward-right-down: PX4's body frame, insid's b (no mounting applied)"},
          {"sign",
           "bias = measured - true, as insid's sensor model (PX4's estimator subtracts its "
           "bias estimates from the IMU data)"},
          {"imported_imu", imu_topic + " instance " + std::to_string(imu_instance)},
          {"which_imu",
           "the IMU the estimator fuses; sensor_combined and instance 0 of vehicle_imu carry PX4's "
           "primary IMU, normally the same one (the log's device ids would settle it)"},
          {"uncertainty",
           "sd_si: the square root of the estimator's own variance of the last "
           "message (when the layout logs *_bias_variance); log_sd_si: the spread of "
           "the estimate over the log"},
          {"estimates", list}};
}

}  // namespace insid::importers
