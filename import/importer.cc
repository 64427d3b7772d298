#include "import/importer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>

#include "base/number_text.h"
#include "data/gnss_interpolation.h"
#include "model/earth.h"
#include "model/units.h"
#include "nav/alignment.h"
#include "nav/fitness.h"

namespace insid::importers {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// heading.csv from a heading input (assemble_dataset's rules), into out.dataset.
void add_heading(const HeadingInput& in, const AssembleOptions& options, GpstTime t_origin,
                 Assembled& out) {
  Dataset& ds = out.dataset;
  const bool magnetometer = in.source == HeadingSourceKind::kMagnetometer;
  const double t0 = ds.imu.front().t_s;
  const double t1 = magnetometer ? t0 + ds.meta.align_s : ds.imu.back().t_s;
  if (magnetometer && !(ds.meta.align_s > 0.0))
    throw std::runtime_error(
        "a magnetometer heading needs a static window to level it on (align_s is 0)");
  // The static window's mean specific force (the levelling of the tilt compensation).
  Eigen::Vector3d f_mean_b = Eigen::Vector3d::Zero();
  if (magnetometer) {
    const std::optional<Eigen::Vector3d> f = mean_specific_force_b(ds.imu, t1);
    if (!f) throw std::runtime_error("the static window holds fewer than 2 IMU rows");
    f_mean_b = *f;
  }
  const double declination_rad = options.declination_deg.value_or(0.0) * kDegToRad;
  std::size_t outside = 0, repeated = 0;
  bool all_sd = true;
  for (std::size_t k = 0; k < in.t_gpst_unix_s.size(); ++k) {
    const double t = static_cast<double>(in.t_gpst_unix_s[k] - t_origin);
    if (t < t0 - 1e-9 || t > t1 + 1e-9) {
      ++outside;
      continue;
    }
    if (!ds.heading.empty() && !(t > ds.heading.back().t_s)) {
      ++repeated;
      continue;
    }
    HeadingSample s;
    s.t_s = t;
    if (magnetometer) {
      try {
        s.yaw_rad = magnetometer_true_heading_rad(in.mag_b[k], f_mean_b, declination_rad);
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error(in.origin + ", sample at line/message " +
                                 std::to_string(in.line[k]) + ": " + e.what());
      }
    } else {
      s.yaw_rad = std::remainder(in.yaw_rad[k], 2.0 * 3.14159265358979323846);
      s.sd_rad = in.sd_rad[k];
      all_sd = all_sd && s.sd_rad.has_value();
    }
    ds.heading.push_back(s);
  }
  if (ds.heading.empty())
    throw std::runtime_error(
        "the heading source (" + in.origin + ") has no sample inside " +
        (magnetometer ? "the static window (the magnetometer is levelled on it)"
                      : "the span the dataset keeps") +
        " of " + number_text(t1 - t0, 6) + " s; import without it, or check the source's times");
  if (!all_sd)  // heading.csv gives an sd for every row or none
    for (HeadingSample& s : ds.heading) s.sd_rad.reset();
  HeadingMeta meta;
  meta.source = in.source;
  if (magnetometer) meta.declination_deg = options.declination_deg;
  ds.meta.heading = meta;
  nlohmann::json& prov = out.provenance["heading"];
  prov = {{"source", to_string(in.source)},
          {"from", in.origin},
          {"samples_read", in.t_gpst_unix_s.size()},
          {"samples_used", ds.heading.size()},
          {"outside_span", outside},
          {"repeated_time", repeated},
          {"sd", all_sd ? "from the source" : "none (not given for every sample)"},
          {"frame", "true heading of the body x axis, clockwise from true north"}};
  if (magnetometer) {
    const EulerAngles tilt = euler_from_C_b_n(level_with_yaw(f_mean_b, 0.0));
    prov["declination_deg"] = *options.declination_deg;
    prov["tilt_compensation"] = {
        {"roll_deg", tilt.roll_rad / kDegToRad},
        {"pitch_deg", tilt.pitch_rad / kDegToRad},
        {"how",
         "levelled with the static window's mean specific force; samples outside the "
         "static window are not written (the importer does not know the tilt there)"}};
  }
  out.notes.push_back("heading: " + std::to_string(ds.heading.size()) + " " + to_string(in.source) +
                      " samples (" + in.origin + ")" +
                      (magnetometer ? ", declination " + number_text(*options.declination_deg, 6) +
                                          " deg added, tilt-compensated on the static window"
                                    : std::string()));
}

}  // namespace

std::string AssembleOptions::validate() const {
  if (gnss_quality.empty()) return "--gnss-quality: give at least one RTKLIB quality flag (1-6)";
  for (int q : gnss_quality)
    if (q < 1 || q > 7) return "--gnss-quality: flag " + std::to_string(q) + " is not in 1-7";
  if (align_s && !(std::isfinite(*align_s) && *align_s >= 0.0 && *align_s <= 86400.0))
    return "--align-s " + number_text(*align_s, 6) +
           ": must be a finite number of seconds in [0, 86400]";
  if (!(std::isfinite(static_speed_mps) && static_speed_mps > 0.0 && static_speed_mps <= 10.0))
    return "--static-speed " + number_text(static_speed_mps, 6) + ": must be in (0, 10] m/s";
  if (!(std::isfinite(min_imu_rate_hz) && min_imu_rate_hz > 0.0 && min_imu_rate_hz <= 10000.0))
    return "--min-imu-rate-hz " + number_text(min_imu_rate_hz, 6) + ": must be in (0, 10000] Hz";
  if (!(std::isfinite(static_rate_dps) && static_rate_dps > 0.0 && static_rate_dps <= 1000.0))
    return "--static-rate " + number_text(static_rate_dps, 6) + ": must be in (0, 1000] deg/s";
  if (!(std::isfinite(static_accel_sd_mps2) && static_accel_sd_mps2 > 0.0 &&
        static_accel_sd_mps2 <= 100.0))
    return "--static-accel-sd " + number_text(static_accel_sd_mps2, 6) +
           ": must be in (0, 100] m/s^2";
  if (declination_deg && !(std::isfinite(*declination_deg) && std::fabs(*declination_deg) <= 180.0))
    return "--declination-deg " + number_text(*declination_deg, 6) +
           ": must be within [-180, 180] deg";
  return "";
}

ImuStaticEnd static_window_end(const std::vector<ImuSample>& imu, double t_limit_s,
                               const AssembleOptions& options) {
  constexpr double kBlockS = 0.5;
  ImuStaticEnd out{t_limit_s, ""};
  if (imu.size() < 2) return out;
  const double t0 = imu.front().t_s;
  const double rate_limit = options.static_rate_dps * kDegToRad;
  Eigen::Vector3d dtheta_still = Eigen::Vector3d::Zero();  // over the still blocks so far
  double dt_still = 0.0;
  std::size_t k = 1;
  for (int block = 0;; ++block) {
    const double t_start = t0 + block * kBlockS, t_stop = t_start + kBlockS;
    if (t_stop > t_limit_s + 1e-9) break;  // only whole blocks inside the GNSS-still span
    Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
    double dt = 0.0, sum_f = 0.0, sum_f2 = 0.0;
    int n = 0;
    for (; k < imu.size() && imu[k].t_s <= t_stop + 1e-9; ++k) {
      const double step = imu[k].t_s - imu[k - 1].t_s;
      if (!(step > 0.0)) continue;
      dtheta += imu[k].dtheta_b_rad;
      dt += step;
      const double f = imu[k].dv_b_mps.norm() / step;  // |specific force| of the row (m/s^2)
      sum_f += f;
      sum_f2 += f * f;
      ++n;
    }
    if (n < 2) continue;
    // Mean angular rate of the block against the mean over the still blocks before it.
    if (dt_still > 0.0) {
      const Eigen::Vector3d departure = dtheta / dt - dtheta_still / dt_still;
      const int axis = [&] {
        Eigen::Index i = 0;
        departure.cwiseAbs().maxCoeff(&i);
        return static_cast<int>(i);
      }();
      if (std::abs(departure[axis]) > rate_limit) {
        out.t_end_s = std::max(t0, t_start - kBlockS);
        out.why = "the mean angular rate of the block at t = " + number_text(t_start - t0, 6) +
                  " s departs from the still blocks' by " +
                  number_text(departure[axis] / kDegToRad, 3) + " deg/s on " + "xyz"[axis] +
                  " (above --static-rate " + number_text(options.static_rate_dps, 6) + ")";
        return out;
      }
    }
    const double mean_f = sum_f / n;
    const double sd_f = std::sqrt(std::max(0.0, (sum_f2 - n * mean_f * mean_f) / (n - 1)));
    if (sd_f > options.static_accel_sd_mps2) {
      out.t_end_s = std::max(t0, t_start - kBlockS);
      out.why = "the specific force of the block at t = " + number_text(t_start - t0, 6) +
                " s scatters by " + number_text(sd_f, 3) + " m/s^2 (above --static-accel-sd " +
                number_text(options.static_accel_sd_mps2, 6) + ")";
      return out;
    }
    dtheta_still += dtheta;
    dt_still += dt;
  }
  return out;
}

namespace {

// The heading source agrees with --declination-deg: required with a magnetometer (insid has no
// magnetic model), refused otherwise.
void check_declination(const HeadingInput* heading, const AssembleOptions& options) {
  const bool magnetometer = heading && heading->source == HeadingSourceKind::kMagnetometer;
  if (magnetometer && !options.declination_deg)
    throw std::invalid_argument(
        "--declination-deg is required with a magnetometer heading: the magnetic declination "
        "(deg, east +) at the flight, from a world magnetic model or a chart; insid has no "
        "magnetic model and will not guess it");
  if (!magnetometer && options.declination_deg)
    throw std::invalid_argument("--declination-deg " + number_text(*options.declination_deg, 6) +
                                " applies to a magnetometer heading only, and this import has " +
                                (heading ? "a dual-antenna heading" : "no heading source"));
}

// The GNSS epochs of an accepted quality (--gnss-quality); the others counted by quality flag.
std::vector<GnssEpoch> accepted_epochs(const GnssSolution& gnss, const AssembleOptions& options,
                                       Assembled& out) {
  nlohmann::json& prov = out.provenance;
  std::vector<GnssEpoch> kept;
  std::map<int, int> dropped;
  for (const GnssEpoch& e : gnss.epochs) {
    if (options.gnss_quality.count(e.quality))
      kept.push_back(e);
    else
      ++dropped[e.quality];
  }
  int dropped_total = 0;
  for (const auto& [q, n] : dropped) {
    dropped_total += n;
    prov["gnss"]["dropped_by_quality"][std::to_string(q)] = n;
  }
  if (dropped_total > 0)
    out.notes.push_back("dropped " + std::to_string(dropped_total) + " of " +
                        std::to_string(gnss.epochs.size()) +
                        " GNSS epochs whose quality flag is "
                        "not accepted (--gnss-quality)");
  if (kept.size() < 2)
    throw std::runtime_error(
        "only " + std::to_string(kept.size()) +
        " GNSS epochs have an accepted quality flag (--gnss-quality); need at least 2");
  return kept;
}

// The IMU rows used: rows k in [first, last] inside the GNSS span (a rate also needs the row
// before `first`, the interval's start), and the dataset's time origin.
struct ImuSpan {
  bool increments = false;  // both sensors give increments (else a rate is integrated)
  std::size_t first = 0;
  std::size_t last = 0;
  GpstTime t_origin = 0;  // a whole GPST second
};

// The common span of the IMU and the accepted GNSS epochs; refuses data that do not overlap or
// fewer than 3 IMU rows inside it.
ImuSpan imu_span(const CsvImu& imu, const std::vector<GnssEpoch>& kept, Assembled& out) {
  const GpstTime tg0 = kept.front().t_gpst_unix_s, tg1 = kept.back().t_gpst_unix_s;
  const GpstTime ti0 = imu.t_gpst_unix_s.front(), ti1 = imu.t_gpst_unix_s.back();
  if (!(ti0 < tg1 && tg0 < ti1))
    throw std::runtime_error("the GNSS solution (GPST " +
                             number_text(static_cast<double>(tg0), 13) + " to " +
                             number_text(static_cast<double>(tg1), 13) +
                             " s since 1970) does not overlap the IMU data (" +
                             number_text(static_cast<double>(ti0), 13) + " to " +
                             number_text(static_cast<double>(ti1), 13) +
                             " s); check --imu-time, --gps-week and --imu-time-offset-s");
  // IMU rows k in [first, last] inside the span; rates need the previous row (the interval's
  // start), increments do not.
  const bool increments = imu.gyro_is_increment && imu.accel_is_increment;
  std::size_t first = increments ? 0 : 1;
  while (first < imu.t_gpst_unix_s.size() && imu.t_gpst_unix_s[first] < tg0) ++first;
  std::size_t last = imu.t_gpst_unix_s.size() - 1;
  while (last > first && imu.t_gpst_unix_s[last] > tg1) --last;
  if (last < first + 2) throw std::runtime_error("fewer than 3 IMU rows inside the GNSS span");
  const GpstTime t_origin = std::floor(imu.t_gpst_unix_s[first]);
  out.provenance["time_origin_gpst_unix_s"] = static_cast<double>(t_origin);  // a whole second
  return {increments, first, last, t_origin};
}

// Where each dataset IMU row came from, and the steps between the rows.
struct ImuRows {
  std::vector<double> steps;       // s, between consecutive rows
  std::vector<std::size_t> lines;  // the source line of each dataset row
  std::vector<std::size_t> bytes;  // and its byte offset (binary logs)
};

// out.dataset.imu: increments over each row's own interval of the span, accelerations in g-local
// scaled by the normal gravity at the first accepted GNSS epoch.
ImuRows add_imu_increments(const CsvImu& imu, const ImuSpan& span, const GnssEpoch& first_epoch,
                           Assembled& out) {
  nlohmann::json& prov = out.provenance;
  ImuRows rows;
  double g_local = 1.0;
  if (imu.accel_in_g_local) {
    g_local =
        EarthModel::wgs84().normal_gravity_mps2(first_epoch.lat_deg * kDegToRad, first_epoch.h_m);
    prov["imu"]["g_local_mps2"] = g_local;
  }
  Dataset& ds = out.dataset;
  for (std::size_t k = span.first; k <= span.last; ++k) {
    rows.lines.push_back(k < imu.line.size() ? imu.line[k] : 0);
    if (k < imu.byte.size()) rows.bytes.push_back(imu.byte[k]);
    const double dt =
        k > 0 ? static_cast<double>(imu.t_gpst_unix_s[k] - imu.t_gpst_unix_s[k - 1]) : 0.0;
    ImuSample s;
    s.t_s = static_cast<double>(imu.t_gpst_unix_s[k] - span.t_origin);
    // The rule is per sensor: a rate is integrated (trapezoid), an increment passes through.
    const auto increment = [&](const std::vector<Eigen::Vector3d>& v, bool is_increment,
                               double scale) {
      if (is_increment) return Eigen::Vector3d(v[k] * scale);
      if (k == 0) throw std::logic_error("a rate needs the previous row");
      if (imu.rates_are_interval_means) return Eigen::Vector3d(v[k] * scale * dt);
      return Eigen::Vector3d(0.5 * (v[k - 1] + v[k]) * scale * dt);
    };
    s.dtheta_b_rad = increment(imu.gyro_b, imu.gyro_is_increment, 1.0);
    s.dv_b_mps = increment(imu.accel_b, imu.accel_is_increment, g_local);
    ds.imu.push_back(s);
    if (k > span.first) rows.steps.push_back(dt);
  }
  return rows;
}

// Every row of the source counted in the provenance: used, or dropped with its reason (the
// reader's, then the span's; a rate's first row only opens the first interval), and how the rows
// were integrated.
void record_imu_rows(const CsvImu& imu, const ImuSpan& span, Assembled& out) {
  nlohmann::json& prov = out.provenance;
  const std::size_t n = imu.t_gpst_unix_s.size();
  std::map<std::string, std::size_t> rows_dropped = imu.rows_dropped;
  // Rates: the row before `first` opens the first interval (in or before the span).
  const std::size_t opens_interval = span.increments ? 0 : 1;
  rows_dropped["interval_start"] += opens_interval;
  rows_dropped["before_gnss_span"] = span.first - opens_interval;
  rows_dropped["after_gnss_span"] = n - 1 - span.last;
  std::size_t total = 0;
  for (const auto& [why, count] : rows_dropped) total += count;
  const std::size_t source_rows = imu.source_rows > 0 ? imu.source_rows : n;
  prov["imu"]["rows_read"] = source_rows;
  prov["imu"]["rows_used"] = out.dataset.imu.size();
  prov["imu"]["rows_dropped"] = rows_dropped;
  if (total + out.dataset.imu.size() != source_rows)
    throw std::logic_error("assemble_dataset: IMU rows used and dropped do not add up");
  if (total > 0) {
    std::string why;
    const std::map<std::string, std::string> words = {
        {"repeated_timestamp", "with a repeated timestamp"},
        {"timestamp_jump", "in timestamp jumps"},
        {"interval_start", "opening the first interval"},
        {"before_gnss_span", "before the GNSS span"},
        {"after_gnss_span", "after the GNSS span"}};
    for (const auto& [reason, count] : rows_dropped)
      if (count > 0)
        why += (why.empty() ? "" : ", ") + std::to_string(count) + " " +
               (words.count(reason) ? words.at(reason) : reason);
    out.notes.push_back("IMU: " + std::to_string(out.dataset.imu.size()) + " of " +
                        std::to_string(source_rows) + " rows used; dropped: " + why);
  }
  prov["imu"]["first_line_used"] = imu.line[span.first];
  prov["imu"]["last_line_used"] = imu.line[span.last];
  prov["imu"]["integration"] =
      span.increments ? "increments as given"
      : imu.rates_are_interval_means
          ? "rates as means over each row's own interval, w[k] * (t[k] - t[k-1])"
          : "rates integrated over each row's own interval by the trapezoidal rule, "
            "(w[k-1] + w[k]) / 2 * (t[k] - t[k-1])";
}

// The IMU's median step; refuses a rate below options.min_imu_rate_hz.
double checked_imu_step(const CsvImu& imu, const std::vector<double>& steps,
                        const std::vector<ImuSample>& imu_rows, const AssembleOptions& options,
                        Assembled& out) {
  nlohmann::json& prov = out.provenance;
  const double dt_median = median(steps);
  // The IMU's rate against the lowest insid integrates (kDefaultMinImuRateHz: why).
  // (A relative 1e-6 below the minimum still passes: time tags printed with 6-9 digits.)
  if (const double rate_hz = 1.0 / dt_median; !(rate_hz >= options.min_imu_rate_hz * (1.0 - 1e-6)))
    throw std::runtime_error(
        (imu.origin.empty() ? std::string("the IMU") : imu.origin) + ": IMU rate " +
        number_text(rate_hz, 3) + " Hz (median step " + number_text(dt_median * 1e3, 4) + " ms; " +
        number_text(
            static_cast<double>(steps.size()) / (imu_rows.back().t_s - imu_rows.front().t_s), 3) +
        " Hz on average over " + std::to_string(steps.size()) + " steps) is below the " +
        number_text(options.min_imu_rate_hz, 4) +
        " Hz insid accepts for strapdown integration: a multicopter moves at up to ~5 Hz, and at " +
        number_text(rate_hz, 3) + " Hz everything above " + number_text(rate_hz / 2, 3) +
        " Hz (the Nyquist frequency) is aliased and what happens between the samples is lost; "
        "nothing was written. Log the IMU faster (PX4: SDLOG_PROFILE high-rate, or the "
        "vehicle_imu topic; ArduPilot: the IMU logging rate), or give --min-imu-rate-hz R "
        "(R <= " +
        number_text(rate_hz, 3) + ") for a platform whose motion stays below R / 4 Hz");
  // The median alone lets a mixed-rate log through (e.g. half at 50 Hz, half at 10 Hz):
  // the time spent in steps slower than the minimum rate counts too.
  const double slow_step_s = 1.0 / options.min_imu_rate_hz * (1.0 + 1e-6);
  double slow_s = 0.0, total_s = 0.0, slowest_s = 0.0;
  for (const double step : steps) {
    total_s += step;
    if (step > slow_step_s) slow_s += step, slowest_s = std::max(slowest_s, step);
  }
  if (total_s > 0.0 && slow_s > 0.1 * total_s)
    throw std::runtime_error(
        (imu.origin.empty() ? std::string("the IMU") : imu.origin) + ": " +
        number_text(100.0 * slow_s / total_s, 3) + " % of the log (" + number_text(slow_s, 4) +
        " s of " + number_text(total_s, 4) + " s) is sampled slower than the " +
        number_text(options.min_imu_rate_hz, 4) + " Hz insid accepts (steps up to " +
        number_text(slowest_s * 1e3, 4) + " ms), although the median step (" +
        number_text(dt_median * 1e3, 4) +
        " ms) passes: a log whose rate changes; nothing was written. Cut it to the fast part "
        "(--t-start / --t-end where the importer has them), or give --min-imu-rate-hz R for a "
        "platform whose motion stays below R / 4 Hz");
  prov["imu"]["min_rate_hz"] = options.min_imu_rate_hz;
  prov["imu"]["slow_step_share"] = total_s > 0.0 ? slow_s / total_s : 0.0;
  prov["imu"]["step_s"] = {{"median", dt_median},
                           {"min", *std::min_element(steps.begin(), steps.end())},
                           {"max", *std::max_element(steps.begin(), steps.end())}};
  return dt_median;
}

// Where each dataset GNSS row came from, and the steps between the rows.
struct GnssRows {
  std::vector<double> steps;       // s, between consecutive rows
  std::vector<std::size_t> lines;  // the source line of each dataset row
};

// out.dataset.gnss: the accepted epochs inside the IMU span (ENU velocity), outages noted.
// Refuses fewer than 2.
GnssRows add_gnss_epochs(const GnssSolution& gnss, const std::vector<GnssEpoch>& kept,
                         const ImuSpan& span, const AssembleOptions& options, Assembled& out) {
  nlohmann::json& prov = out.provenance;
  GnssRows rows;
  Dataset& ds = out.dataset;
  std::vector<double> sd_v;
  for (const GnssEpoch& e : kept) {
    const double t = static_cast<double>(e.t_gpst_unix_s - span.t_origin);
    if (t < ds.imu.front().t_s - 1e-9 || t > ds.imu.back().t_s + 1e-9) continue;
    GnssSample g;
    g.t_s = t;
    g.lat_rad = e.lat_deg * kDegToRad;
    g.lon_rad = e.lon_deg * kDegToRad;
    g.h_m = e.h_m;
    g.v_eb_n_mps = {e.v_e_mps, e.v_n_mps, e.v_u_mps};
    if (!ds.gnss.empty()) rows.steps.push_back(t - ds.gnss.back().t_s);
    ds.gnss.push_back(g);
    rows.lines.push_back(e.line);
    sd_v.push_back(std::hypot(e.sd_vn_mps, e.sd_ve_mps));
  }
  if (ds.gnss.size() < 2) throw std::runtime_error("fewer than 2 GNSS epochs inside the IMU span");
  // GNSS outages: steps longer than 3 median periods (longer than the dataset allows are refused
  // by the dataset checks, naming the line).
  {
    const double period = median(rows.steps);
    nlohmann::json outages = nlohmann::json::array();
    for (std::size_t k = 1; k < ds.gnss.size(); ++k) {
      const double gap = ds.gnss[k].t_s - ds.gnss[k - 1].t_s;
      if (gap <= 3.0 * period) continue;
      outages.push_back({{"after_t_s", ds.gnss[k - 1].t_s}, {"gap_s", gap}});
      if (outages.size() <= 5)
        out.notes.push_back("GNSS outage of " + number_text(gap, 6) +
                            " s after t = " + number_text(ds.gnss[k - 1].t_s, 6) + " s");
    }
    prov["gnss"]["outages"] = outages;
  }
  prov["gnss"]["epochs_read"] = gnss.epochs.size();
  prov["gnss"]["epochs_used"] = ds.gnss.size();
  prov["gnss"]["format"] = gnss.format;
  prov["gnss"]["accepted_quality"] = options.gnss_quality;
  prov["gnss"]["median_horizontal_velocity_sd_mps"] = median(sd_v);
  prov["gnss"]["weighting"] = "none: every kept epoch counts equally in the fitness";
  return rows;
}

// meta.json "motors": the source's motor intervals on the dataset's clock, kept where they
// overlap the IMU rows (clipped to them).
void add_motors(const CsvImu& imu, const ImuSpan& span, Assembled& out) {
  if (imu.motors_on_gpst.empty()) return;
  DatasetMeta& m = out.dataset.meta;
  const double t0 = out.dataset.imu.front().t_s, t1 = out.dataset.imu.back().t_s;
  for (const auto& [on, off] : imu.motors_on_gpst) {
    const double t_on = std::max(t0, static_cast<double>(on - span.t_origin));
    const double t_off = std::min(t1, static_cast<double>(off - span.t_origin));
    if (t_on < t_off) m.motors.on_s.emplace_back(t_on, t_off);
  }
  m.motors_source = imu.motors_source;
  out.provenance["motors"] = {{"source", imu.motors_source}, {"on_s", m.motors.on_s}};
  std::string spans;
  for (std::size_t i = 0; i < m.motors.on_s.size() && i < 4; ++i)
    spans += (i ? ", " : "") + number_text(m.motors.on_s[i].first, 6) + " - " +
             number_text(m.motors.on_s[i].second, 6) + " s";
  if (m.motors.on_s.size() > 4) spans += ", ... (" + std::to_string(m.motors.on_s.size()) + ")";
  if (spans.empty()) {
    out.notes.push_back("motor outputs (" + imu.motors_source +
                        "): no run inside the data: the motor state stays unknown (no motor "
                        "offsets)");
    return;
  }
  out.notes.push_back("motors running (" + imu.motors_source + "): " + spans +
                      " (meta.json motors; the motor offsets of the error model use them)");
}

// The static alignment window: --align-s, else from the first IMU row to the earliest of 1 s
// before the GNSS first shows motion, the IMU's own end of stillness (static_window_end) and the
// motor start (vibration moves a MEMS sensor's offsets: a window with the motors running
// levels with them); and the initial state at the first IMU row (interpolated GNSS). Refuses a
// window under 1 s.
void set_static_window_and_start(const AssembleOptions& options, Assembled& out) {
  nlohmann::json& prov = out.provenance;
  Dataset& ds = out.dataset;
  DatasetMeta& m = ds.meta;
  const double t_motors =
      m.motors.empty() ? std::numeric_limits<double>::infinity() : m.motors.on_s.front().first;
  if (options.align_s) {
    m.align_s = *options.align_s;
    prov["alignment_window"] = {{"align_s", m.align_s}, {"how", "given (--align-s)"}};
    if (t_motors < ds.imu.front().t_s + m.align_s)
      out.notes.push_back("the static window (--align-s " + number_text(m.align_s, 6) + ") holds " +
                          number_text(ds.imu.front().t_s + m.align_s - t_motors, 4) +
                          " s with the motors running: the alignment levels with their "
                          "vibration offsets");
  } else {
    double t_moving = ds.gnss.back().t_s;
    for (const GnssSample& g : ds.gnss)
      if (std::hypot(g.v_eb_n_mps.x(), g.v_eb_n_mps.y()) > options.static_speed_mps) {
        t_moving = g.t_s;
        break;
      }
    // The GNSS sees translation only: the IMU criteria end the window earlier at a turn on the
    // spot or handling (static_window_end); the motor start ends it too.
    ImuStaticEnd imu_end = static_window_end(ds.imu, t_moving - 1.0, options);
    const double t_imu_end = imu_end.why.empty() ? t_moving - 1.0 : imu_end.t_end_s;
    const bool by_motors = t_motors < t_imu_end;
    if (by_motors) {
      imu_end.t_end_s = t_motors;
      imu_end.why = "the motors start at t = " + number_text(t_motors - ds.imu.front().t_s, 6) +
                    " s (" + m.motors_source + ")";
    }
    // (The block starts lie on 0.5 s steps from the first row: the 1e-9 keeps 9.0 from reading
    // 8.9 by round-off; the GNSS end is floored to 0.1 s.)
    m.align_s = imu_end.why.empty()
                    ? std::floor((t_moving - 1.0 - ds.imu.front().t_s) * 10.0) / 10.0
                    : std::floor((imu_end.t_end_s - ds.imu.front().t_s) * 10.0 + 1e-9) / 10.0;
    if (m.align_s < 1.0)
      throw std::runtime_error(
          "no static start found: " +
          (imu_end.why.empty()
               ? "the GNSS horizontal speed exceeds " + number_text(options.static_speed_mps, 6) +
                     " m/s within " + number_text(t_moving - ds.imu.front().t_s, 6) +
                     " s of the first IMU row"
               : imu_end.why) +
          "; give the static window with --align-s");
    prov["alignment_window"] = {
        {"align_s", m.align_s},
        {"how",
         "from the first IMU row to the earlier of 1 s before the first GNSS epoch with "
         "horizontal speed above " +
             number_text(options.static_speed_mps, 6) +
             " m/s and the 0.5 s IMU block before the first one that moves (mean rate departing "
             "by more than " +
             number_text(options.static_rate_dps, 6) + " deg/s, or |specific force| sd above " +
             number_text(options.static_accel_sd_mps2, 6) + " m/s^2)" +
             (m.motors.empty() ? "" : ", and the motor start")},
        {"ended_by", imu_end.why.empty() ? std::string("gnss speed") : imu_end.why},
        {"gnss_moving_t_s", t_moving - ds.imu.front().t_s}};
    if (!imu_end.why.empty())
      out.notes.push_back(std::string(by_motors ? "static window ended before the GNSS moved: "
                                                : "static window ended by the IMU before the "
                                                  "GNSS moved: ") +
                          imu_end.why);
  }
  out.notes.push_back("static alignment window: the first " + number_text(m.align_s, 6) + " s");
  const GnssSample g0 = interpolate_gnss(ds.gnss, ds.imu.front().t_s);
  m.initial.t_s = ds.imu.front().t_s;
  m.initial.lat_rad = g0.lat_rad;
  m.initial.lon_rad = g0.lon_rad;
  m.initial.h_m = g0.h_m;
  m.initial.v_eb_n_mps = g0.v_eb_n_mps;
  m.initial_attitude_known = false;
}

// The IMU's gaps (imu_gaps) in the provenance, the first ones in the notes.
void record_imu_gaps(double dt_median, Assembled& out) {
  nlohmann::json& prov = out.provenance;
  const Dataset& ds = out.dataset;
  const std::vector<ImuGap> gaps = imu_gaps(ds);
  for (const ImuGap& gap : gaps) {
    prov["imu"]["gaps"].push_back({{"t_s", gap.t_s}, {"dt_s", gap.dt_s}});
    if (out.notes.size() < 12)
      out.notes.push_back("IMU gap of " + number_text(gap.dt_s, 6) +
                          " s before t = " + number_text(gap.t_s, 6) + " s (" +
                          number_text(gap.dt_s / dt_median, 3) + " median steps)");
  }
  if (gaps.empty()) prov["imu"]["gaps"] = nlohmann::json::array();
}

}  // namespace

Assembled assemble_dataset(const CsvImu& imu, const GnssSolution& gnss,
                           const AssembleOptions& options, const HeadingInput* heading) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  if (!heading && imu.heading) heading = &*imu.heading;
  check_declination(heading, options);
  Assembled out;
  const std::vector<GnssEpoch> kept = accepted_epochs(gnss, options, out);
  const ImuSpan span = imu_span(imu, kept, out);
  const ImuRows imu_rows = add_imu_increments(imu, span, kept.front(), out);
  record_imu_rows(imu, span, out);
  const double dt_median = checked_imu_step(imu, imu_rows.steps, out.dataset.imu, options, out);
  const GnssRows gnss_rows = add_gnss_epochs(gnss, kept, span, options, out);
  DatasetMeta& m = out.dataset.meta;
  m.format = DatasetFormat::kV2;
  m.earth = EarthModel::wgs84();
  m.imu_rate_hz = 1.0 / dt_median;
  m.gnss_rate_hz = 1.0 / median(gnss_rows.steps);
  // Errors name the user's files and options: nothing has been written yet.
  DatasetSources sources;
  sources.row = [&](std::string_view file, std::size_t row) -> std::string {
    const auto name = [](const std::string& source, const std::string& unit,
                         const std::vector<std::size_t>& lines,
                         const std::vector<std::size_t>& bytes, std::size_t r) -> std::string {
      if (source.empty() || r >= lines.size() || lines[r] == 0) return "";
      return source + " " + unit + " " + std::to_string(lines[r]) +
             (r < bytes.size() ? " (byte " + std::to_string(bytes[r]) + ")" : "");
    };
    if (file == "imu.csv")
      return name(imu.origin, imu.row_unit, imu_rows.lines, imu_rows.bytes, row);
    if (file == "gnss.csv") return name(gnss.source, gnss.row_unit, gnss_rows.lines, {}, row);
    return "";
  };
  sources.field = [&](std::string_view field) -> std::string {
    if (field != "align_s") return "";
    return options.align_s ? "--align-s" : "the detected static window (align_s)";
  };
  // A damaged sample (a flipped exponent bit: 1e19 m/s^2) is named by its record and byte
  // before the static window is looked for in the data it would spoil.
  validate_imu_values(out.dataset, sources);
  add_motors(imu, span, out);
  set_static_window_and_start(options, out);
  record_imu_gaps(dt_median, out);
  if (heading) add_heading(*heading, options, span.t_origin, out);
  validate_dataset(out.dataset, sources);
  return out;
}

}  // namespace insid::importers
