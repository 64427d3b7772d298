#include "data/plausibility.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>

#include "base/number_text.h"
#include "model/units.h"

namespace insid {
namespace {

using Eigen::Vector3d;

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

std::string num(double v, int digits = 3) { return number_text(v, digits); }

// The cumulative sums of the IMU increments against time, for the mean rate or specific force
// over any interval (each row's increment spread evenly over its step).
class ImuCumulative {
 public:
  explicit ImuCumulative(const std::vector<ImuSample>& imu) {
    t_.reserve(imu.size() + 1);
    theta_.reserve(imu.size() + 1);
    v_.reserve(imu.size() + 1);
    const double first_dt = imu.size() > 1 ? imu[1].t_s - imu[0].t_s : 0.01;
    t_.push_back(imu.front().t_s - first_dt);
    theta_.push_back(Vector3d::Zero());
    v_.push_back(Vector3d::Zero());
    for (const ImuSample& s : imu) {
      t_.push_back(s.t_s);
      theta_.push_back(theta_.back() + s.dtheta_b_rad);
      v_.push_back(v_.back() + s.dv_b_mps);
    }
  }
  double begin() const { return t_.front(); }
  double end() const { return t_.back(); }
  // The sums at time t (clamped to the data).
  Vector3d theta_at(double t) const { return at(theta_, t); }
  Vector3d v_at(double t) const { return at(v_, t); }

 private:
  Vector3d at(const std::vector<Vector3d>& sums, double t) const {
    if (t <= t_.front()) return sums.front();
    if (t >= t_.back()) return sums.back();
    const std::size_t k = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) -
                                                   t_.begin());  // t_[k-1] <= t < t_[k]
    const double w = (t - t_[k - 1]) / (t_[k] - t_[k - 1]);
    return sums[k - 1] + w * (sums[k] - sums[k - 1]);
  }
  std::vector<double> t_;
  std::vector<Vector3d> theta_, v_;
};

// ENU displacement (m) from GNSS sample a to b.
Vector3d displacement_enu(const EarthModel& earth, const GnssSample& a, const GnssSample& b) {
  const double lat = 0.5 * (a.lat_rad + b.lat_rad), h = 0.5 * (a.h_m + b.h_m);
  double dlon = b.lon_rad - a.lon_rad;
  if (dlon > std::numbers::pi) dlon -= 2 * std::numbers::pi;
  if (dlon < -std::numbers::pi) dlon += 2 * std::numbers::pi;
  return {dlon * (earth.prime_vertical_radius_m(lat) + h) * std::cos(lat),
          (b.lat_rad - a.lat_rad) * (earth.meridian_radius_m(lat) + h), b.h_m - a.h_m};
}

double median_step(const std::vector<GnssSample>& g) {
  std::vector<double> d;
  for (std::size_t k = 1; k < g.size(); ++k) d.push_back(g[k].t_s - g[k - 1].t_s);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

// Pairs of GNSS epochs (k, k + n) at least `baseline_s` apart, stepping by n.
std::vector<std::pair<std::size_t, std::size_t>> baselines(const std::vector<GnssSample>& g,
                                                           double baseline_s) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  const double step = median_step(g);
  if (!(step > 0.0)) return out;
  const std::size_t n =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(baseline_s / step)));
  for (std::size_t k = 0; k + n < g.size(); k += n) {
    const double dt = g[k + n].t_s - g[k].t_s;
    if (dt > 0.5 * baseline_s && dt < 3.0 * baseline_s) out.emplace_back(k, k + n);
  }
  return out;
}

// The name of a unit mix-up whose stored / true factor is near `s`, or "".
std::string scale_cause(double s, const std::string& what) {
  struct Known {
    double factor;
    const char* cause;
  };
  static const std::array<Known, 6> kKnown = {{{3.6, "in km/h, read as m/s"},
                                               {1.0 / 3.6, "in m/s, read as km/h"},
                                               {1.943844, "in knots, read as m/s"},
                                               {1.0 / 1.943844, "in m/s, read as knots"},
                                               {kRadToDeg, "in deg/s, read as rad/s"},
                                               {1.0 / kRadToDeg, "in rad/s, read as deg/s"}}};
  for (const Known& k : kKnown)
    if (std::abs(std::log(std::abs(s) / k.factor)) < 0.15)
      return what + " look " + k.cause + (s < 0 ? ", and negated" : "");
  return "";
}

void check_static(const Dataset& ds, PlausibilityReport& report) {
  const double t_end = ds.imu.front().t_s + ds.meta.align_s;
  Vector3d f_sum = Vector3d::Zero(), w_sum = Vector3d::Zero(), w_sq = Vector3d::Zero();
  double t_sum = 0.0;
  int n = 0;
  for (std::size_t k = 1; k < ds.imu.size() && ds.imu[k].t_s <= t_end; ++k) {
    const double dt = ds.imu[k].t_s - ds.imu[k - 1].t_s;
    if (!(dt > 0.0)) continue;
    const Vector3d w = ds.imu[k].dtheta_b_rad / dt;
    f_sum += ds.imu[k].dv_b_mps;
    w_sum += ds.imu[k].dtheta_b_rad;
    w_sq += w.cwiseProduct(w);
    t_sum += dt;
    ++n;
  }
  if (n < 20 || t_sum < 1.0) {
    report.not_checked.push_back("static_gravity, static_earth_rate: no static window of 1 s (" +
                                 num(t_sum) + " s)");
    return;
  }
  const double lat = ds.meta.initial.lat_rad, h = ds.meta.initial.h_m;
  const double g = ds.meta.earth.normal_gravity_mps2(lat, h);
  const Vector3d f_mean_b = f_sum / t_sum;
  const double f = f_mean_b.norm();
  const double off_g = std::abs(f - g) / kStandardGravity_mps2;
  if (off_g > 0.1) {
    PlausibilityFinding x;
    x.level =
        off_g > 0.5 ? PlausibilityFinding::Level::kRefusal : PlausibilityFinding::Level::kWarning;
    x.check = "static_gravity";
    x.quantity = "the static window's mean specific force magnitude";
    x.expected = num(g, 4) + " m/s^2 (normal gravity at " + num(lat * kRadToDeg, 4) + " deg, " +
                 num(h, 4) + " m; a MEMS accelerometer is within 0.08 g of it)";
    x.found = num(f, 4) + " m/s^2 (" + num(f / g, 3) + " g)";
    if (std::abs(f / g * kStandardGravity_mps2 - 1.0) < 0.05)
      x.likely_cause = "the accelerations look like g, not m/s^2";
    else if (std::abs(f / g / kStandardGravity_mps2 - 1.0) < 0.05)
      x.likely_cause = "the accelerations look like m/s^2 scaled once more by g";
    else
      x.likely_cause = "a wrong accelerometer unit or scale, or a window that is not static";
    report.findings.push_back(x);
  }
  // The body frame at rest is forward-right-down: on a vehicle standing on its wheels, skids or
  // feet the specific force (up) lies within 90 deg of -z. Beyond it the frame is upside down.
  const double tilt = std::acos(std::clamp(-f_mean_b.z() / f, -1.0, 1.0));
  if (tilt > std::numbers::pi / 2) {
    PlausibilityFinding x;
    x.check = "static_attitude";
    x.quantity = "the static window's specific force direction in the body frame";
    x.expected = "up, within 90 deg of -z (forward-right-down body axes, vehicle at rest)";
    x.found = num(tilt * kRadToDeg, 3) + " deg from -z (f_b = [" + num(f_mean_b.x(), 3) + ", " +
              num(f_mean_b.y(), 3) + ", " + num(f_mean_b.z(), 3) + "] m/s^2)";
    x.likely_cause =
        "the body frame looks upside down at rest: a mounting rotation (--mounting-rpy-deg) "
        "off by 180 deg about a horizontal axis, or the z axis sign";
    report.findings.push_back(x);
  }
  // The Earth rate, where the window's noise lets it be seen.
  const Vector3d w_mean = w_sum / t_sum;
  const Vector3d var = (w_sq / n - (w_sum / t_sum).cwiseProduct(w_sum / t_sum)).cwiseMax(0.0);
  const double se = std::sqrt(var.sum() / n);
  const double earth = ds.meta.earth.omega_ie_rad_s;
  if (se > 0.1 * earth) {
    report.not_checked.push_back("static_earth_rate: the static window's noise (standard error " +
                                 num(se * kRadToDeg * 3600.0) +
                                 " deg/h) hides the Earth rate (15.04 deg/h)");
  } else if (w_mean.norm() < 0.2 * earth) {
    PlausibilityFinding x;
    x.check = "static_earth_rate";
    x.quantity = "the static window's mean rotation rate";
    x.expected = "about the Earth rate, " + num(earth * kRadToDeg * 3600.0, 4) +
                 " deg/h (standard error here " + num(se * kRadToDeg * 3600.0, 2) + " deg/h)";
    x.found = num(w_mean.norm() * kRadToDeg * 3600.0, 3) + " deg/h";
    x.likely_cause = std::abs(std::log(earth / w_mean.norm() / kRadToDeg)) < 0.3
                         ? "the gyros look scaled down by 57.3: rad/s read as deg/s"
                         : "the gyros look scaled down (a wrong unit), or the data are not raw";
    report.findings.push_back(x);
  }
}

void check_turns(const Dataset& ds, const ImuCumulative& imu, PlausibilityReport& report) {
  double sxy = 0.0, sxx = 0.0, syy = 0.0, turned = 0.0;
  int n = 0;
  const auto& g = ds.gnss;
  for (const auto& [a, b] : baselines(g, 1.0)) {
    const Vector3d va = g[a].v_eb_n_mps, vb = g[b].v_eb_n_mps;
    if (std::hypot(va.x(), va.y()) < 1.0 || std::hypot(vb.x(), vb.y()) < 1.0) continue;
    if (g[a].t_s < imu.begin() || g[b].t_s > imu.end()) continue;
    double d_course = std::atan2(vb.x(), vb.y()) - std::atan2(va.x(), va.y());
    d_course = std::remainder(d_course, 2.0 * std::numbers::pi);
    const Vector3d dv = imu.v_at(g[b].t_s) - imu.v_at(g[a].t_s);
    if (dv.norm() <= 0.0) continue;
    const Vector3d up_b = dv.normalized();  // the specific force's direction, about up
    // Heading (clockwise from north) turns opposite to the rotation about up.
    const double d_heading = -(imu.theta_at(g[b].t_s) - imu.theta_at(g[a].t_s)).dot(up_b);
    sxy += d_heading * d_course;
    sxx += d_heading * d_heading;
    syy += d_course * d_course;
    turned += std::abs(d_course);
    ++n;
  }
  if (turned < std::numbers::pi / 2 || sxx <= 0.0 || syy <= 0.0) {
    report.not_checked.push_back(
        "gyro_turn_rate: fewer than 90 deg of GNSS course change above 1 m/s (" +
        num(turned * kRadToDeg) + " deg)");
    return;
  }
  const double slope = sxy / sxx;  // course change per gyro heading change
  const double corr = sxy / std::sqrt(sxx * syy);
  if (std::abs(corr) < 0.5) {  // no scale to read (a clock offset, say): the other checks tell
    report.not_checked.push_back("gyro_turn_rate: the gyro and GNSS turns do not correlate (" +
                                 num(corr) + ")");
    return;
  }
  if (slope > 0.7 && slope < 1.4) return;
  PlausibilityFinding x;
  x.check = "gyro_turn_rate";
  x.quantity = "GNSS course change per heading change the gyros measure, while moving";
  x.expected = "1 (" + num(turned * kRadToDeg, 4) + " deg of turns compared)";
  x.found = num(slope, 4) + " (correlation " + num(corr, 3) + ")";
  const std::string cause = scale_cause(1.0 / slope, "the gyro rates");  // stored / true
  x.likely_cause = !cause.empty() ? cause
                   : slope < 0 ? "the gyros' vertical axis looks inverted (an axis convention or "
                                 "a mounting flip)"
                               : "a wrong gyro scale or unit";
  report.findings.push_back(x);
}

void check_gnss_velocity(const Dataset& ds, PlausibilityReport& report) {
  // Fit the positions' velocity on the given one: v_pos = B v_given (horizontal 2 x 2, and
  // the vertical slope), over baselines of >= 2 s (position noise / 2 s stays small).
  Eigen::Matrix2d sxx = Eigen::Matrix2d::Zero(), syx = Eigen::Matrix2d::Zero();
  double zx = 0.0, zxx = 0.0;
  int n = 0;
  const auto& g = ds.gnss;
  for (const auto& [a, b] : baselines(g, 2.0)) {
    const double dt = g[b].t_s - g[a].t_s;
    const Vector3d v_pos = displacement_enu(ds.meta.earth, g[a], g[b]) / dt;
    Vector3d v_given = Vector3d::Zero();  // the trapezoid of the given velocities over [a, b]
    for (std::size_t k = a; k < b; ++k)
      v_given += 0.5 * (g[k].v_eb_n_mps + g[k + 1].v_eb_n_mps) * (g[k + 1].t_s - g[k].t_s);
    v_given /= dt;
    const Eigen::Vector2d x = v_given.head<2>(), y = v_pos.head<2>();
    sxx += x * x.transpose();
    syx += y * x.transpose();
    zx += v_pos.z() * v_given.z();
    zxx += v_given.z() * v_given.z();
    ++n;
  }
  const double horizontal_motion = n > 0 ? std::sqrt(sxx.trace() / n) : 0.0;
  if (n < 10 || horizontal_motion < 1.0 ||
      std::abs(sxx.determinant()) < 1e-6 * sxx.trace() * sxx.trace()) {
    report.not_checked.push_back("gnss_velocity (horizontal): too little motion (rms " +
                                 num(horizontal_motion) + " m/s over " + std::to_string(n) +
                                 " baselines of 2 s)");
  } else {
    const Eigen::Matrix2d B = syx * sxx.inverse();
    const double off = (B - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff();
    if (off > 0.2) {
      PlausibilityFinding x;
      x.check = "gnss_velocity";
      x.quantity = "the GNSS positions' rate of change against the GNSS velocity (east, north)";
      x.expected = "the identity [[1, 0], [0, 1]]";
      x.found = "[[" + num(B(0, 0)) + ", " + num(B(0, 1)) + "], [" + num(B(1, 0)) + ", " +
                num(B(1, 1)) + "]]";
      const double d = 0.2;
      if (std::abs(B(0, 0)) < d && std::abs(B(1, 1)) < d && std::abs(B(0, 1) - 1) < d &&
          std::abs(B(1, 0) - 1) < d)
        x.likely_cause = "the east and north velocities look swapped";
      else if ((B + Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff() < d)
        x.likely_cause = "the horizontal velocities look negated";
      else if (std::abs(B(0, 0) + 1) < d && std::abs(B(1, 1) - 1) < d)
        x.likely_cause = "the east velocity looks negated";
      else if (std::abs(B(0, 0) - 1) < d && std::abs(B(1, 1) + 1) < d)
        x.likely_cause = "the north velocity looks negated";
      else if (std::abs(B(0, 1)) < d && std::abs(B(1, 0)) < d &&
               std::abs(B(0, 0) / B(1, 1) - 1) < 0.1) {
        // v_given = v_true / B: the unit's factor is 1 / B.
        x.likely_cause = scale_cause(1.0 / (0.5 * (B(0, 0) + B(1, 1))), "the velocities");
        if (x.likely_cause.empty()) x.likely_cause = "the velocities look scaled (a wrong unit)";
      } else {
        x.likely_cause = "velocity and position disagree: a wrong axis order, sign or unit";
      }
      report.findings.push_back(x);
    }
  }
  if (n < 10 || zxx < 1.0 * n * 0.04) {  // rms vertical speed below 0.2 m/s
    report.not_checked.push_back("gnss_velocity (vertical): too little vertical motion");
    return;
  }
  const double slope = zx / zxx;
  if (std::abs(slope - 1.0) > 0.3) {
    PlausibilityFinding x;
    x.check = "gnss_velocity";
    x.quantity = "the GNSS heights' rate of change against the GNSS vertical velocity";
    x.expected = "1";
    x.found = num(slope);
    const std::string cause = scale_cause(1.0 / slope, "the vertical velocities");
    x.likely_cause = slope < -0.7 && slope > -1.3 ? "the vertical velocity looks down, not up"
                     : !cause.empty()             ? cause
                                                  : "a wrong vertical velocity sign or unit";
    report.findings.push_back(x);
  }
}

void check_clock(const Dataset& ds, const ImuCumulative& imu, PlausibilityReport& report) {
  const auto& g = ds.gnss;
  const double step = median_step(g);
  if (!(step > 0.0)) return;
  // The GNSS side on a regular grid: q_gnss = |a|^2 + 2 g a_up over 1 s baselines.
  struct Point {
    double t_mid, dt, q;
  };
  std::vector<Point> gnss_q;
  const double gravity =
      ds.meta.earth.normal_gravity_mps2(ds.meta.initial.lat_rad, ds.meta.initial.h_m);
  for (const auto& [a, b] : baselines(g, 1.0)) {
    const double dt = g[b].t_s - g[a].t_s;
    const Vector3d acc = (g[b].v_eb_n_mps - g[a].v_eb_n_mps) / dt;
    gnss_q.push_back(
        {0.5 * (g[a].t_s + g[b].t_s), dt, acc.squaredNorm() + 2.0 * gravity * acc.z()});
  }
  auto imu_q = [&](double t_mid, double dt) {
    const Vector3d f = (imu.v_at(t_mid + 0.5 * dt) - imu.v_at(t_mid - 0.5 * dt)) / dt;
    return f.squaredNorm() - gravity * gravity;
  };
  // The correlation of the two at an IMU clock shift `lag` (the IMU's stamp of the same
  // instant is t + lag), over the epochs both cover.
  auto correlation = [&](double lag) -> std::optional<double> {
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    int n = 0;
    for (const Point& p : gnss_q) {
      const double t = p.t_mid + lag;
      if (t - p.dt < imu.begin() || t + p.dt > imu.end()) continue;
      const double x = p.q, y = imu_q(t, p.dt);
      sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
      ++n;
    }
    if (n < 30) return std::nullopt;
    const double cov = sxy / n - sx / n * sy / n;
    const double vx = sxx / n - sx / n * sx / n, vy = syy / n - sy / n * sy / n;
    if (!(vx > 0 && vy > 0)) return std::nullopt;
    return cov / std::sqrt(vx * vy);
  };
  const std::optional<double> at_zero = correlation(0.0);
  if (!at_zero) {
    report.not_checked.push_back("imu_gnss_clock: fewer than 30 epochs with accelerations");
    return;
  }
  double best_lag = 0.0, best = *at_zero;
  const double lag_step = std::max(step, 0.1);
  for (double lag = -30.0; lag <= 30.0 + 1e-9; lag += lag_step) {
    const std::optional<double> c = correlation(lag);
    if (c && *c > best) best = *c, best_lag = lag;
  }
  if (best < 0.5) {
    report.not_checked.push_back(
        "imu_gnss_clock: the accelerations seen by the IMU and the GNSS "
        "correlate too weakly at any shift (best " +
        num(best) + ")");
    return;
  }
  if (std::abs(best_lag) < std::max(0.5, 2.0 * step) || best - *at_zero < 0.2) return;
  PlausibilityFinding x;
  x.check = "imu_gnss_clock";
  x.quantity =
      "the shift of the IMU clock against the GNSS clock at which the accelerations "
      "both see match best";
  x.expected = "0 s (correlation there " + num(*at_zero) + ")";
  x.found = num(best_lag, 3) + " s (correlation " + num(best) + ")";
  x.likely_cause = std::abs(std::abs(best_lag) - 18.0) < 1.0
                       ? "the IMU and GNSS time scales differ by the GPS-UTC leap seconds (18 s)"
                       : "the IMU and GNSS clocks are offset (a wrong --imu-time-offset-s, time "
                         "scale or week)";
  report.findings.push_back(x);
}

}  // namespace

std::string PlausibilityFinding::text() const {
  return std::string(level == Level::kRefusal ? "implausible data (refused): "
                                              : "implausible data: ") +
         quantity + ": expected " + expected + ", found " + found + ": " + likely_cause;
}

nlohmann::json PlausibilityFinding::to_json() const {
  return {{"level", level == Level::kRefusal ? "refusal" : "warning"},
          {"check", check},
          {"quantity", quantity},
          {"expected", expected},
          {"found", found},
          {"likely_cause", likely_cause}};
}

bool PlausibilityReport::refused() const {
  for (const PlausibilityFinding& f : findings)
    if (f.level == PlausibilityFinding::Level::kRefusal) return true;
  return false;
}

nlohmann::json PlausibilityReport::to_json() const {
  nlohmann::json j = {{"findings", nlohmann::json::array()}, {"not_checked", not_checked}};
  for (const PlausibilityFinding& f : findings) j["findings"].push_back(f.to_json());
  return j;
}

PlausibilityReport check_plausibility(const Dataset& dataset) {
  PlausibilityReport report;
  if (dataset.imu.size() < 2 || dataset.gnss.size() < 2) {
    report.not_checked.push_back("every check: fewer than two IMU rows or GNSS epochs");
    return report;
  }
  const ImuCumulative imu(dataset.imu);
  check_static(dataset, report);
  check_turns(dataset, imu, report);
  check_gnss_velocity(dataset, report);
  check_clock(dataset, imu, report);
  return report;
}

}  // namespace insid
