#include "import/ardupilot_import.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "base/number_text.h"
#include "data/dataset.h"  // PlausibilityBounds::kMaxImuStep_s
#include "import/log_damage.h"
#include "import/timestamps.h"
#include "model/units.h"

namespace insid::importers {
namespace {

// Least squares y = a + b x on the rows `use` of x, y (boot s, GPST s since the GPS epoch).
void fit_line(const std::vector<long double>& x, const std::vector<long double>& y,
              const std::vector<char>& use, long double& a, long double& b) {
  long double n = 0, mx = 0, my = 0;
  for (std::size_t k = 0; k < x.size(); ++k)
    if (use[k]) n += 1, mx += x[k], my += y[k];
  mx /= n, my /= n;
  long double sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k)
    if (use[k]) sxx += (x[k] - mx) * (x[k] - mx), sxy += (x[k] - mx) * (y[k] - my);
  b = sxx > 0 ? sxy / sxx : 1.0L;
  a = my - b * mx;
}

constexpr double kG0 = 9.80665;

}  // namespace

nlohmann::json autopilot_bias_estimates(const DataFlashFile& log, const FlightPhases& phases,
                                        const ArduPilotImportOptions& options,
                                        std::vector<std::string>& notes) {
  struct Field {
    const char* message;
    const char* field;
    char letter;           // the FMT letter ArduPilot writes it with
    double to_si;          // from the reader's value (letter scaling applied) to SI
    const char* effect;    // insid's catalogue name
    const char* imu;       // the IMU (or IMUs) it refers to
    const char* logged;    // how it is logged
    double resolution_si;  // one logged step
  };
  constexpr double kDegS = kPi / 180.0;  // deg/s -> rad/s
  // Which gyro EKF1's biases belong to: NavEKF of the Copter 3.3 era (AP_NavEKF readIMUData,
  // June-November 2015 versions) integrates the mean of the first two gyros' delta angles when
  // both are healthy ("dual gyro mode - average first two gyros"), the primary gyro's alone
  // otherwise; its gyro bias states are therefore the biases of that mean. EKF2's AZ1bias and
  // AZ2bias are the z biases of the first and second accelerometer (the EKF fuses both).
  constexpr const char* kGyroMean = "IMU+IMU2";
  const Field fields[] = {
      {"EKF1", "GX", 'c', kDegS, "gyro_bias_x", kGyroMean,
       "int16 centi-deg/s (FMT c: x 0.01 deg/s)", 0.01 * kDegS},
      {"EKF1", "GY", 'c', kDegS, "gyro_bias_y", kGyroMean,
       "int16 centi-deg/s (FMT c: x 0.01 deg/s)", 0.01 * kDegS},
      {"EKF1", "GZ", 'c', kDegS, "gyro_bias_z", kGyroMean,
       "int16 centi-deg/s (FMT c: x 0.01 deg/s)", 0.01 * kDegS},
      {"EKF2", "AZ1bias", 'b', 0.01, "accel_bias_z", "IMU", "int8 cm/s^2 (FMT b, 100 x m/s^2)",
       0.01},
      {"EKF2", "AZ2bias", 'b', 0.01, "accel_bias_z", "IMU2", "int8 cm/s^2 (FMT b, 100 x m/s^2)",
       0.01},
  };
  if (log.count("EKF1") == 0 && log.count("EKF2") == 0) return nullptr;
  const double t_start_s = options.t_start_s.value_or(-1.0);
  const double t_end_s = options.t_end_s.value_or(1e300);
  const bool airborne = phases.airborne();
  const double air_from_s = airborne ? std::max(*phases.takeoff_s, t_start_s) : 0.0;
  const double air_to_s = airborne ? std::min(phases.airborne_end_s, t_end_s) : 0.0;
  nlohmann::json list = nlohmann::json::array();
  std::string summary;
  for (const Field& f : fields) {
    if (log.count(f.message) == 0 || !log.has_field(f.message, "TimeMS")) continue;
    const char letter = log.field_type(f.message, f.field);
    if (letter == 0) continue;
    if (letter != f.letter) {
      notes.push_back(std::string("autopilot estimate ") + f.message + "." + f.field +
                      " left out: its FMT letter is '" + letter + "', not the '" + f.letter +
                      "' whose scale ArduPilot's Log_Write_EKF documents");
      continue;
    }
    const auto rows = log.read(f.message, {"TimeMS", f.field});
    std::optional<double> end_si, end_boot_s;
    double sum = 0, sum2 = 0;
    std::size_t n = 0;
    for (const auto& r : rows) {
      const double t = r[0] * 1e-3, v = r[1] * f.to_si;
      if (t < t_start_s || t > t_end_s) continue;
      end_si = v, end_boot_s = t;
      if (airborne && t >= air_from_s && t <= air_to_s) sum += v, sum2 += v * v, ++n;
    }
    if (!end_si) continue;
    const double mean = n > 0 ? sum / static_cast<double>(n) : 0.0;
    const double sd = n > 1
                          ? std::sqrt(std::max(0.0, (sum2 - static_cast<double>(n) * mean * mean) /
                                                        static_cast<double>(n - 1)))
                          : 0.0;
    const bool gyro = f.effect[0] == 'g';
    const double display = gyro ? 180.0 / kPi : 1e3 / kG0;  // SI -> deg/s or mg
    nlohmann::json e = {
        {"effect", f.effect},
        {"source", std::string(f.message) + "." + f.field},
        {"imu", f.imu},
        {"applies_to_imported_imu", options.imu == f.imu},
        {"refers_to", f.imu == std::string(kGyroMean)
                          ? "the mean of IMU's and IMU2's gyros (NavEKF's dual-gyro mode)"
                          : f.imu + std::string("'s accelerometer")},
        {"logged_as", f.logged},
        {"si_unit", gyro ? "rad/s" : "m/s^2"},
        {"end_boot_s", *end_boot_s},
        {"end_si", *end_si},
        {"airborne_records", n},
        {"airborne_mean_si", n > 0 ? nlohmann::json(mean) : nlohmann::json(nullptr)},
        {"airborne_sd_si", n > 1 ? nlohmann::json(sd) : nlohmann::json(nullptr)},
        {"resolution_si", f.resolution_si},
        {"display_unit", gyro ? "deg/s" : "mg"},
        {"end_display", *end_si * display},
        {"airborne_mean_display", n > 0 ? nlohmann::json(mean * display) : nlohmann::json(nullptr)},
        {"airborne_sd_display", n > 1 ? nlohmann::json(sd * display) : nlohmann::json(nullptr)}};
    list.push_back(e);
    summary += (summary.empty() ? "" : "; ") + std::string(f.effect) + " (" + f.imu + ") " +
               number_text(*end_si * display, 3) +
               (n > 1 ? ", airborne " + number_text(mean * display, 3) + " +- " +
                            number_text(sd * display, 2)
                      : std::string()) +
               " " + (gyro ? "deg/s" : "mg");
  }
  if (list.empty()) return nullptr;
  notes.push_back(
      "autopilot EKF bias estimates (meta.json autopilot_estimates; at the end of the "
      "window" +
      std::string(airborne ? ", airborne mean +- sd" : "") + "): " + summary);
  return {
      {"autopilot", "ArduPilot NavEKF (EKF1/EKF2 log messages)"},
      {"frame", "body forward-right-down: ArduPilot's body axes, insid's b (no mounting applied)"},
      {"sign",
       "bias = measured - true, as insid's sensor model (the EKF subtracts its bias "
       "states from the IMU's increments)"},
      {"imported_imu", options.imu},
      {"which_imu",
       "EKF1 GX/GY/GZ: the one gyro the NavEKF integrates (the primary, normally "
       "IMU); EKF2 AZ1bias/AZ2bias: the z accelerometers of IMU and IMU2"},
      {"window_boot_s",
       {options.t_start_s ? nlohmann::json(*options.t_start_s) : nlohmann::json(nullptr),
        options.t_end_s ? nlohmann::json(*options.t_end_s) : nlohmann::json(nullptr)}},
      {"airborne_boot_s",
       airborne ? nlohmann::json{air_from_s, air_to_s} : nlohmann::json(nullptr)},
      {"uncertainty",
       "the EKF logs no variance of its bias states: airborne_sd_si is the sample sd "
       "of the logged estimate over the airborne part (how far it wanders, not a "
       "standard error); resolution_si is one logged step"},
      {"estimates", list}};
}

std::string ArduPilotImportOptions::validate() const {
  if (imu != "IMU" && imu != "IMU2" && imu != "IMU3")
    return "--imu '" + imu + "': must be IMU, IMU2 or IMU3 (the log's IMU messages)";
  if (min_status < 0 || min_status > 6) return "--min-status: must be in 0-6";
  for (const auto& [name, v] : {std::pair{"--t-start", t_start_s}, std::pair{"--t-end", t_end_s}})
    if (v && !(std::isfinite(*v) && *v >= 0.0 && *v <= 1e7))
      return std::string(name) + ": must be boot seconds in 0-1e7";
  if (t_start_s && t_end_s && !(*t_start_s < *t_end_s))
    return "--t-start " + number_text(*t_start_s, 4) + " must be before --t-end " +
           number_text(*t_end_s, 4);
  return "";
}

namespace {

// The GPS records' fields extract_ardupilot reads, in this order.
enum GpsField { kStatus, kTow, kWeek, kSats, kLat, kLng, kAlt, kSpd, kCrs, kVz, kBoot };
using Records = std::vector<std::vector<double>>;

// GPST seconds since the GPS epoch of GPS record k (Week, TimeMS).
long double gpst_since_epoch(const Records& gps, std::size_t k) {
  return static_cast<long double>(gps[k][kWeek]) * kSecondsPerWeek +
         static_cast<long double>(gps[k][kTow]) * 1e-3L;
}

// The boot clock on GPST: a line fitted over every fix of the log (`fixes`: indices into gps),
// then again without the fixes beyond kBootFitOutlierS (records logged late, e.g. in a burst
// after a logging gap).
BootClockFit fit_boot_clock(const Records& gps, const std::vector<std::size_t>& fixes,
                            const std::string& where) {
  BootClockFit clock;
  std::vector<long double> x, y;
  for (const std::size_t k : fixes) {
    x.push_back(static_cast<long double>(gps[k][kBoot]) * 1e-3L);
    y.push_back(gpst_since_epoch(gps, k));
  }
  std::vector<char> use(x.size(), 1);
  // A damaged fix (one flipped bit in Week, TimeMS or T) must not pull the first line off every
  // other fix: fixes whose GPST - boot offset is more than 1 s from the median offset (the clocks
  // drift by far less over a flight) stay out of it.
  if (!x.empty()) {
    std::vector<long double> offsets;
    for (std::size_t k = 0; k < x.size(); ++k) offsets.push_back(y[k] - x[k]);
    std::vector<long double> sorted = offsets;
    std::nth_element(sorted.begin(),
                     sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const long double median = sorted[sorted.size() / 2];
    for (std::size_t k = 0; k < x.size(); ++k)
      if (!(std::fabs(static_cast<double>(offsets[k] - median)) <= 1.0)) use[k] = 0;
  }
  long double a = 0, b = 1;
  fit_line(x, y, use, a, b);
  std::fill(use.begin(), use.end(), 1);
  for (std::size_t k = 0; k < x.size(); ++k)
    if (std::fabs(static_cast<double>(y[k] - (a + b * x[k]))) > kBootFitOutlierS) {
      use[k] = 0;
      ++clock.excluded;
    }
  if (x.size() - clock.excluded < 2)
    throw std::runtime_error(where +
                             ": GPS boot times (T) and GPS times (Week, TimeMS) do not "
                             "follow a line: fewer than 2 fixes within " +
                             number_text(kBootFitOutlierS, 4) + " s of the fit");
  fit_line(x, y, use, a, b);
  double ss = 0;
  for (std::size_t k = 0; k < x.size(); ++k)
    if (use[k]) {
      const double r = static_cast<double>(y[k] - (a + b * x[k]));
      ss += r * r;
      clock.max_abs_s = std::max(clock.max_abs_s, std::fabs(r));
    }
  clock.fixes = x.size() - clock.excluded;
  clock.rms_s = std::sqrt(ss / static_cast<double>(clock.fixes));
  clock.gpst_at_boot_zero_s = kGpsEpochGpstUnix_s + a;
  clock.slope = static_cast<double>(b);
  return clock;
}

// True when fix i's GPS time (Week, TimeMS) lies 0-5 s after the previous fix's and 0-5 s
// before the next one's (where there is one): in step with the fixes around it.
bool in_step_with_neighbours(const Records& gps, const std::vector<std::size_t>& fixes,
                             std::size_t i) {
  const long double t = gpst_since_epoch(gps, fixes[i]);
  const auto step_ok = [](long double dt) { return dt > 0.0L && dt <= 5.0L; };
  const bool after_previous = i == 0 || step_ok(t - gpst_since_epoch(gps, fixes[i - 1]));
  const bool before_next =
      i + 1 == fixes.size() || step_ok(gpst_since_epoch(gps, fixes[i + 1]) - t);
  return after_previous && before_next && (i > 0 || i + 1 < fixes.size());
}

// VZ's sign: the altitude's rate (central differences over fixes at most 1 s apart) against VZ.
VzSign vz_sign_of(const Records& gps, const std::vector<std::size_t>& fixes) {
  VzSign vz;
  double sxy = 0, sxx = 0, syy = 0, mx = 0, my = 0;
  std::vector<std::pair<double, double>> pairs;  // (VZ, dAlt/dt)
  for (std::size_t i = 1; i + 1 < fixes.size(); ++i) {
    const std::size_t p = fixes[i - 1], k = fixes[i], q = fixes[i + 1];
    const double dt = static_cast<double>(gpst_since_epoch(gps, q) - gpst_since_epoch(gps, p));
    if (!(dt > 0.0 && dt <= 1.0)) continue;
    pairs.emplace_back(gps[k][kVz], (gps[q][kAlt] - gps[p][kAlt]) / dt);
  }
  for (const auto& [v, d] : pairs) mx += v, my += d;
  vz.pairs = pairs.size();
  if (!pairs.empty()) {
    mx /= static_cast<double>(pairs.size()), my /= static_cast<double>(pairs.size());
    double sx0 = 0;
    for (const auto& [v, d] : pairs) {
      sx0 += v * d;
      sxx += (v - mx) * (v - mx), syy += (d - my) * (d - my), sxy += (v - mx) * (d - my);
    }
    double svv = 0;
    for (const auto& [v, d] : pairs) svv += v * v;
    vz.s = svv > 0 ? sx0 / svv : 0.0;
    vz.correlation = sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
  }
  vz.conclusive = vz.pairs >= 20 && std::fabs(vz.correlation) >= 0.5;
  vz.down_positive = vz.conclusive ? vz.s < 0.0 : true;
  return vz;
}

// The median step of the kept IMU records (ms) and the steps longer than kImuGapMedianSteps of
// it, into out.imu_gaps_boot_s and provenance imu.boot_gaps.
double median_step_and_gaps_ms(const Records& rows, ArduPilotSeries& out) {
  std::vector<double> steps;
  std::vector<double> boot_ms;
  for (const std::size_t line : out.imu.line) boot_ms.push_back(rows[line - 1][0]);
  for (std::size_t k = 1; k < boot_ms.size(); ++k) steps.push_back(boot_ms[k] - boot_ms[k - 1]);
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median_ms = sorted[sorted.size() / 2];
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t k = 0; k < steps.size(); ++k)
    if (steps[k] > kImuGapMedianSteps * median_ms) {
      out.imu_gaps_boot_s.emplace_back(boot_ms[k] * 1e-3, steps[k] * 1e-3);
      list.push_back({{"after_boot_s", boot_ms[k] * 1e-3}, {"gap_s", steps[k] * 1e-3}});
    }
  out.provenance["imu"]["boot_gaps"] = list;
  return median_ms;
}

// The flight's phases over the whole log: the chosen IMU's records whose stamps were kept
// (`rows`: TimeMS, gyro, accelerometer; `kept`: their indices, stamps increasing), every fix.
FlightPhases phases_of_log(const Records& rows, const std::vector<std::size_t>& kept,
                           const Records& gps, const std::vector<std::size_t>& fixes) {
  FlightPhaseInput in;
  double previous_ms = -1.0;
  std::vector<double> gap_ends_s;
  for (const std::size_t k : kept) {
    const auto& r = rows[k];
    if (!std::all_of(r.begin(), r.end(), [](double v) { return std::isfinite(v); })) continue;
    if (previous_ms >= 0.0 && (r[0] - previous_ms) * 1e-3 > PlausibilityBounds::kMaxImuStep_s)
      gap_ends_s.push_back(r[0] * 1e-3);
    previous_ms = r[0];
    in.imu_boot_s.push_back(r[0] * 1e-3);
    in.omega_b_rad_s.emplace_back(r[1], r[2], r[3]);
    in.f_b_mps2.emplace_back(r[4], r[5], r[6]);
  }
  double last_fix_ms = -1.0;
  for (const std::size_t k : fixes) {
    if (!(gps[k][kBoot] > last_fix_ms) || !std::isfinite(gps[k][kAlt]) ||
        !std::isfinite(gps[k][kSpd]))
      continue;
    last_fix_ms = gps[k][kBoot];
    in.gnss_boot_s.push_back(gps[k][kBoot] * 1e-3);
    in.gnss_alt_m.push_back(gps[k][kAlt]);
    in.gnss_speed_mps.push_back(gps[k][kSpd]);
  }
  return find_flight_phases(in, FlightPhaseOptions{}, gap_ends_s);
}

}  // namespace

ArduPilotSeries extract_ardupilot(const DataFlashFile& log, const std::string& where,
                                  const ArduPilotImportOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  ArduPilotSeries out;
  nlohmann::json& prov = out.provenance;
  prov["dataflash"] = {{"messages", log.messages_summary()}};
  record_skipped_damage(log.skip_count(), log.skipped_bytes(), log.skips(), "record", "dataflash",
                        prov, out.notes);
  if (!log.truncation().empty()) {
    prov["dataflash"]["truncation"] = log.truncation();
    out.notes.push_back(log.truncation());
  }
  const double t_start_ms = options.t_start_s ? *options.t_start_s * 1e3 : -1.0;
  const double t_end_ms = options.t_end_s ? *options.t_end_s * 1e3 : 1e300;
  const auto inside = [&](double boot_ms) { return boot_ms >= t_start_ms && boot_ms <= t_end_ms; };

  // GPS first: without it there is nothing to identify against.
  if (log.count("GPS") == 0)
    throw std::runtime_error(where +
                             ": no GPS records: insid identifies sensor errors against "
                             "GNSS velocity, so this log cannot be imported; messages: " +
                             log.messages_summary() + log.damage());
  if (log.count(options.imu) == 0)
    throw std::runtime_error(where + ": no " + options.imu +
                             " records; messages: " + log.messages_summary() + log.damage());
  const Records gps = log.read(
      "GPS", {"Status", "TimeMS", "Week", "NSats", "Lat", "Lng", "Alt", "Spd", "GCrs", "VZ", "T"});
  std::vector<std::size_t> fixes;  // GPS records with Status >= min_status
  for (std::size_t k = 0; k < gps.size(); ++k)
    if (gps[k][kStatus] >= options.min_status) fixes.push_back(k);
  if (fixes.size() < 2)
    throw std::runtime_error(where + ": " + std::to_string(fixes.size()) +
                             " GPS records with "
                             "Status >= " +
                             std::to_string(options.min_status) + " (of " +
                             std::to_string(gps.size()) + "); need at least 2");
  BootClockFit& clock = out.clock;
  clock = fit_boot_clock(gps, fixes, where);
  const auto boot_to_gpst = [&](double boot_ms) {
    return clock.gpst_at_boot_zero_s +
           static_cast<long double>(clock.slope) * static_cast<long double>(boot_ms) * 1e-3L;
  };
  prov["clock"] = {
      {"model",
       "GPST = gpst_at_boot_zero + slope * boot (GPS T, IMU TimeMS), least squares over "
       "the GPS fixes (a first fit without offsets over 1 s from their median), refitted "
       "without residuals beyond " +
           number_text(kBootFitOutlierS, 4) + " s"},
      {"gpst_at_boot_zero_unix_s", static_cast<double>(clock.gpst_at_boot_zero_s)},
      {"slope", clock.slope},
      {"fixes", clock.fixes},
      {"excluded", clock.excluded},
      {"residual_rms_s", clock.rms_s},
      {"residual_max_abs_s", clock.max_abs_s}};
  out.notes.push_back(
      "boot clock tied to GPST by a linear fit over " + std::to_string(clock.fixes) +
      " GPS fixes: slope " + number_text(clock.slope, 8) + ", residual rms " +
      number_text(clock.rms_s * 1e3, 3) + " ms, max " + number_text(clock.max_abs_s * 1e3, 3) +
      " ms" +
      (clock.excluded > 0 ? "; " + std::to_string(clock.excluded) + " fixes logged more than " +
                                number_text(kBootFitOutlierS, 4) + " s off it left out"
                          : std::string()));

  // VZ's sign: the altitude's rate against VZ over the fixes.
  const VzSign& vz = out.vz = vz_sign_of(gps, fixes);
  {
    const std::string evidence = "d(Alt)/dt = " + number_text(vz.s, 3) + " x VZ (correlation " +
                                 number_text(vz.correlation, 3) + ", " + std::to_string(vz.pairs) +
                                 " central differences of Alt over the fixes)";
    prov["gnss"]["vz_sign"] = {{"down_positive", vz.down_positive},
                               {"conclusive", vz.conclusive},
                               {"fit_s", vz.s},
                               {"correlation", vz.correlation},
                               {"pairs", vz.pairs}};
    out.notes.push_back(
        vz.conclusive
            ? std::string("GPS VZ is ") + (vz.down_positive ? "positive down" : "positive up") +
                  " (v_u = " + (vz.down_positive ? "-VZ" : "VZ") + "): " + evidence
            : "GPS VZ taken as positive down (ArduPilot's convention): the altitude does not "
              "tell its sign (" +
                  evidence + ")");
  }

  // GNSS epochs.
  std::size_t outside = 0, not_increasing = 0, clock_disagrees = 0;
  for (std::size_t i = 0; i < fixes.size(); ++i) {
    const std::size_t k = fixes[i];
    const auto& r = gps[k];
    if (!inside(r[kBoot])) {
      ++outside;
      continue;
    }
    GnssEpoch e;
    e.t_gpst_unix_s = kGpsEpochGpstUnix_s + gpst_since_epoch(gps, k);
    // A fix whose own GPS time is over 1 s off the boot clock's line and out of step with its
    // neighbours' GPS times has a damaged Week or TimeMS: dropped and counted, never
    // read as the GNSS's end or a jump. (A fix logged late in a burst is off the line by its T
    // but in step with its neighbours: kept.)
    if (!(std::fabs(static_cast<double>(e.t_gpst_unix_s) -
                    static_cast<double>(boot_to_gpst(r[kBoot]))) <= 1.0) &&
        !in_step_with_neighbours(gps, fixes, i)) {
      ++clock_disagrees;
      continue;
    }
    if (!out.gnss.epochs.empty() && !(e.t_gpst_unix_s > out.gnss.epochs.back().t_gpst_unix_s)) {
      ++not_increasing;
      continue;
    }
    const double course_rad = r[kCrs] * (3.14159265358979323846 / 180.0);
    e.lat_deg = r[kLat];
    e.lon_deg = r[kLng];
    e.h_m = r[kAlt];
    e.v_n_mps = r[kSpd] * std::cos(course_rad);
    e.v_e_mps = r[kSpd] * std::sin(course_rad);
    e.v_u_mps = vz.down_positive ? -r[kVz] : r[kVz];
    e.quality = 1;  // accepted here (Status), kept by assemble_dataset
    e.satellites = r[kSats] >= 0.0 && r[kSats] <= 255.0 ? static_cast<int>(r[kSats]) : 0;
    e.line = k + 1;
    out.gnss.epochs.push_back(e);
  }
  out.gnss.format = "ardupilot dataflash GPS";
  out.gnss.source = where + ", GPS";
  out.gnss.row_unit = "record";
  prov["gnss"]["source"] =
      "GPS: Week + TimeMS (GPS time of week, ms) as GPST; Lat, Lng; Alt "
      "(MSL); v_n, v_e = Spd cos(GCrs), Spd sin(GCrs); v_u from VZ";
  prov["gnss"]["records"] = gps.size();
  prov["gnss"]["dropped"] = {
      {"status_below_" + std::to_string(options.min_status), gps.size() - fixes.size()},
      {"outside_t_range", outside},
      {"time_off_the_boot_clock", clock_disagrees},
      {"time_not_increasing", not_increasing}};
  prov["gnss"]["height"] = "MSL (Alt): the GPS record has no ellipsoidal height";
  out.notes.push_back(
      "GNSS height is MSL (GPS Alt): the log has no ellipsoidal height; heights "
      "only enter as the vertical reference");
  if (gps.size() > fixes.size())
    out.notes.push_back("dropped " + std::to_string(gps.size() - fixes.size()) +
                        " GPS records with Status below " + std::to_string(options.min_status));
  if (not_increasing > 0)
    out.notes.push_back("dropped " + std::to_string(not_increasing) +
                        " GPS fixes whose time (Week, TimeMS) does not increase (a repeated "
                        "time of week: the first record is kept)");
  if (clock_disagrees > 0)
    out.notes.push_back("dropped " + std::to_string(clock_disagrees) +
                        " GPS fixes whose own time (Week, TimeMS) is more than 1 s off the boot "
                        "clock's line through the others (a damaged record)");
  if (out.gnss.epochs.size() < 2)
    throw std::runtime_error(where + ": " + std::to_string(out.gnss.epochs.size()) +
                             " GPS fixes within the boot-time range; need at least 2");

  // IMU.
  const Records rows =
      log.read(options.imu, {"TimeMS", "GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ"});
  const std::vector<std::size_t> imu_bytes = log.offsets(options.imu);
  CsvImu& imu = out.imu;
  imu.origin = where + ", " + options.imu;
  imu.row_unit = "record";
  imu.source_rows = rows.size();
  // A damaged TimeMS costs its own record (one flipped bit must not read as a logging gap, nor
  // make every record after it look out of order): the consistent increasing series is kept.
  const std::size_t time_field = log.field_offset(options.imu, "TimeMS");
  std::vector<double> stamps_us;
  std::vector<std::size_t> stamp_bytes;
  stamps_us.reserve(rows.size());
  stamp_bytes.reserve(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    stamps_us.push_back(rows[k][0] * 1e3);
    stamp_bytes.push_back(imu_bytes.at(k) + time_field);
  }
  const TimestampSelection imu_sel = select_increasing_stamps(stamps_us, stamp_bytes);
  record_stamp_selection(imu_sel, stamps_us, options.imu, "TimeMS", prov["imu"], out.notes);
  std::size_t imu_outside = 0;
  for (const std::size_t k : imu_sel.kept) {
    const auto& r = rows[k];
    if (!inside(r[0])) {
      ++imu_outside;
      continue;
    }
    imu.t_gpst_unix_s.push_back(boot_to_gpst(r[0]));
    imu.gyro_b.emplace_back(r[1], r[2], r[3]);
    imu.accel_b.emplace_back(r[4], r[5], r[6]);
    imu.line.push_back(k + 1);
    imu.byte.push_back(imu_bytes.at(k));
  }
  imu.rows_dropped["outside_t_range"] = imu_outside;
  imu.rows_dropped["repeated_timestamp"] = imu_sel.repeated;
  imu.rows_dropped["timestamp_jump"] = imu_sel.dropped_by_jumps;
  if (imu.t_gpst_unix_s.size() < 3)
    throw std::runtime_error(where + ": " + options.imu + " has " +
                             std::to_string(imu.t_gpst_unix_s.size()) +
                             " records within the boot-time range; need at least 3");
  const double median_step_ms = median_step_and_gaps_ms(rows, out);
  out.phases = phases_of_log(rows, imu_sel.kept, gps, fixes);
  prov["flight_phases"] = out.phases.to_json();
  prov["flight_phases"]["imu"] = options.imu;
  out.autopilot_estimates = autopilot_bias_estimates(log, out.phases, options, out.notes);

  prov["imu"]["source"] = options.imu +
                          ": TimeMS (boot ms), GyrX/Y/Z (rad/s), AccX/Y/Z (m/s^2): "
                          "sampled values, integrated as point samples";
  prov["imu"]["axes"] = "ArduPilot body frame, forward-right-down (no mounting applied)";
  std::string others;
  for (const char* name : {"IMU", "IMU2", "IMU3"})
    if (log.count(name) > 0)
      others += (others.empty() ? "" : ", ") + std::string(name) + " (" +
                std::to_string(log.count(name)) + ")";
  out.notes.push_back("IMU from " + options.imu + " (the log has " + others +
                      "; --imu picks another)");
  const double rate_hz = median_step_ms > 0 ? 1e3 / median_step_ms : 0.0;  // median step
  prov["imu"]["logged_rate_hz"] = rate_hz;
  out.notes.push_back(options.imu + " logs sampled rates and specific forces at " +
                      number_text(rate_hz, 3) +
                      " Hz, not increments: on a multicopter, motor and frame vibration above " +
                      number_text(rate_hz / 2, 3) +
                      " Hz aliases into them and what happens between samples is lost to the "
                      "integration; treat identified gyro and accelerometer errors with care");
  if (const std::optional<MotorRuns> motors = motor_runs_from_rcou(log, out.notes)) {
    for (const auto& [on, off] : motors->on_s)
      imu.motors_on_gpst.emplace_back(boot_to_gpst(on * 1e3), boot_to_gpst(off * 1e3));
    imu.motors_source = motors->source;
  }
  if (options.t_start_s || options.t_end_s) {
    prov["cut_boot_s"] = {
        {"t_start",
         options.t_start_s ? nlohmann::json(*options.t_start_s) : nlohmann::json(nullptr)},
        {"t_end", options.t_end_s ? nlohmann::json(*options.t_end_s) : nlohmann::json(nullptr)}};
    out.notes.push_back(
        "cut to boot time " +
        (options.t_start_s ? number_text(*options.t_start_s, 6) : std::string("start")) + " - " +
        (options.t_end_s ? number_text(*options.t_end_s, 6) : std::string("end")) +
        " s: " + std::to_string(imu_outside) + " IMU records and " + std::to_string(outside) +
        " GPS fixes outside");
  }
  return out;
}

std::optional<MotorRuns> motor_runs_from_rcou(const DataFlashFile& log,
                                              std::vector<std::string>& notes) {
  const std::string kMessage = "RCOU";
  if (log.count(kMessage) == 0 || !log.has_field(kMessage, "TimeMS")) {
    notes.push_back("no RCOU records with TimeMS: the motor state is unknown (no motor offsets)");
    return std::nullopt;
  }
  std::vector<std::string> fields = {"TimeMS"};
  for (int c = 1; c <= kMotorChannels; ++c) {
    const std::string ch = "Ch" + std::to_string(c), short_ch = "C" + std::to_string(c);
    if (log.has_field(kMessage, ch)) {
      fields.push_back(ch);
    } else if (log.has_field(kMessage, short_ch)) {
      fields.push_back(short_ch);
    } else {
      notes.push_back("RCOU has no output " + std::to_string(c) + " (Ch" + std::to_string(c) +
                      " or C" + std::to_string(c) +
                      "): the motor state is unknown (no motor offsets)");
      return std::nullopt;
    }
  }
  const std::vector<std::vector<double>> rows = log.read(kMessage, fields);
  const std::vector<std::size_t> bytes = log.offsets(kMessage);
  const std::size_t time_field = log.field_offset(kMessage, "TimeMS");
  std::vector<double> stamps_us;
  std::vector<std::size_t> stamp_bytes;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    stamps_us.push_back(rows[k][0] * 1e3);
    stamp_bytes.push_back(bytes.at(k) + time_field);
  }
  const TimestampSelection sel = select_increasing_stamps(stamps_us, stamp_bytes);
  nlohmann::json unused;
  record_stamp_selection(sel, stamps_us, kMessage, "TimeMS", unused, notes);
  if (sel.kept.size() < 2) {
    notes.push_back("RCOU has fewer than 2 usable records: the motor state is unknown");
    return std::nullopt;
  }
  return motor_runs(rows, sel.kept, 1e-3, "RCOU " + fields[1] + "-" + fields.back(), notes);
}

}  // namespace insid::importers
