#include "identification/grade.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "base/number_text.h"
#include "data/grade_table.h"
#include "model/rotation.h"
#include "model/units.h"
#include "nav/alignment.h"

namespace insid {
namespace {

// The estimation grades, one per row of the grade table (data/grade_table.h).
const std::vector<SensorGrade>& grades() {
  static const std::vector<SensorGrade> kGrades = [] {
    std::vector<SensorGrade> out;
    for (const GradeFigures& g : grade_table()) out.push_back(SensorGrade{g});
    return out;
  }();
  return kGrades;
}

}  // namespace

double SensorGrade::sigma(std::string_view effect) const {
  const EffectInfo& info = effect_info(effect);  // throws on an unknown name
  const bool gyro = info.sensor == EffectSensor::kGyro;
  switch (info.kind) {
    case EffectKind::kBias:
    case EffectKind::kMotorOffset:  // a bias that steps at motor start: the bias's size
      return gyro ? gyro_bias_rad_s : accel_bias_mps2;
    case EffectKind::kBiasDrift:
      return (gyro ? gyro_bias_rad_s : accel_bias_mps2) / 3600.0;
    case EffectKind::kScale:
      return scale;
    case EffectKind::kMisalign:
      return misalign_rad;
    case EffectKind::kLatency:
    case EffectKind::kLeverArm:
      return info.sigma;  // the GNSS side does not depend on the IMU's grade
  }
  throw std::logic_error("grade '" + std::string(name) + "': no sigma for effect '" +
                         std::string(effect) + "'");
}

PhysicalLimit SensorGrade::physical_limit(std::string_view effect) const {
  const EffectInfo& info = effect_info(effect);  // throws on an unknown name
  const std::string grade_source = std::string(limit_source);
  const bool gyro = info.sensor == EffectSensor::kGyro;
  switch (info.kind) {
    case EffectKind::kBias:
    case EffectKind::kMotorOffset:
      return {gyro ? gyro_bias_limit_rad_s : accel_bias_limit_mps2, grade_source};
    case EffectKind::kBiasDrift:
      return {(gyro ? gyro_bias_limit_rad_s : accel_bias_limit_mps2) / 3600.0, grade_source};
    case EffectKind::kScale:
      return {scale_limit, grade_source};
    case EffectKind::kMisalign:
      return {misalign_limit_rad, grade_source};
    case EffectKind::kLatency:
      return {1.0,
              "a GNSS solution a whole second late at 1-10 Hz: beyond, the clocks are wrong, "
              "not the receiver slow"};
    case EffectKind::kLeverArm:
      return {5.0, "a lever arm longer than a small aircraft (5 m)"};
  }
  throw std::logic_error("grade '" + std::string(name) + "': no physical limit for effect '" +
                         std::string(effect) + "'");
}

EstimatedParameter SensorGrade::parameter(const std::string& text) const {
  EstimatedParameter p = EstimatedParameter::parse(text);
  if (text.find(':') == std::string::npos) p.sigma = sigma(p.name);
  return p;
}

const SensorGrade& sensor_grade(std::string_view name) {
  for (const SensorGrade& g : grades())
    if (g.name == name) return g;
  throw std::invalid_argument("unknown sensor grade '" + std::string(name) +
                              "'; valid grades are: nav, tactical, mems");
}

std::vector<std::string> sensor_grade_names() {
  std::vector<std::string> out;
  for (const SensorGrade& g : grades()) out.emplace_back(g.name);
  return out;
}

std::optional<std::string> declared_grade(const Dataset& dataset) {
  if (!dataset.meta.noise) return std::nullopt;
  const double arw = dataset.meta.noise->arw_deg_rth;
  if (arw <= 0.01) return "nav";
  if (arw <= 0.1) return "tactical";
  return "mems";
}

namespace {

// Coarseness order of the grades: nav < tactical < mems.
int coarseness(std::string_view grade) { return grade == "nav" ? 0 : grade == "tactical" ? 1 : 2; }

}  // namespace

GradeChoice choose_grade(const Dataset& dataset, std::string_view explicit_grade) {
  GradeChoice c;
  if (!explicit_grade.empty() && explicit_grade != "auto") {
    c.grade = std::string(sensor_grade(explicit_grade).name);  // throws on an unknown name
    c.source = "--grade";
    c.rule = "grade " + c.grade + " (given)";
    return c;
  }
  if (const std::optional<std::string> declared = declared_grade(dataset)) {
    c.grade = *declared;
    c.source = "meta.json noise";
    c.arw_deg_rth = dataset.meta.noise->arw_deg_rth;
    c.rule = "grade " + c.grade + " (auto: meta.json noise.arw_deg_rth " +
             number_text(c.arw_deg_rth, 3) +
             " deg/sqrt(h); <= 0.01 nav, <= 0.1 tactical, above mems)";
    return c;
  }
  // The static window: the rows within align_s of the first IMU row.
  const std::vector<ImuSample>& imu = dataset.imu;
  std::size_t end = 0;
  const double t0 = imu.empty() ? 0.0 : imu.front().t_s;
  while (end < imu.size() && imu[end].t_s <= t0 + dataset.meta.align_s) ++end;
  const double window_s = end > 1 ? imu[end - 1].t_s - t0 : 0.0;
  if (window_s < GradeChoice::kMinStaticWindowS || end < 10) {
    c.grade = "nav";
    c.source = "assumed";
    c.rule = "grade nav ASSUMED (auto: no meta.json noise block and no static window of at least " +
             number_text(GradeChoice::kMinStaticWindowS, 3) +
             " s to measure the sensors on; give --grade nav|tactical|mems)";
    return c;
  }
  c.source = "static window";
  c.static_window_s = window_s;
  const double arw_rad_rts = estimate_arw_rad_rts(imu, 1, end, t0);
  c.arw_deg_rth = arw_rad_rts * kRadToDeg * 60.0;                // rad/sqrt(s) -> deg/sqrt(h)
  c.vrw_mps_rth = estimate_vrw_mps_rts(imu, 1, end, t0) * 60.0;  // m/s/sqrt(s) -> m/s/sqrt(h)
  Eigen::Vector3d dtheta_rad = Eigen::Vector3d::Zero();
  for (std::size_t k = 1; k < end; ++k) dtheta_rad += imu[k].dtheta_b_rad;
  const double mean_rate_rad_s = (dtheta_rad / window_s).norm();
  const double kRadSToDegH = kRadToDeg * 3600.0;
  c.gyro_bias_min_deg_h =
      std::abs(mean_rate_rad_s - dataset.meta.earth.omega_ie_rad_s) * kRadSToDegH;
  c.gyro_bias_noise_deg_h = arw_rad_rts / std::sqrt(window_s) * kRadSToDegH;

  const std::string by_arw = c.arw_deg_rth <= 0.01  ? "nav"
                             : c.arw_deg_rth <= 0.1 ? "tactical"
                                                    : "mems";
  const std::string by_vrw = c.vrw_mps_rth <= 0.005   ? "nav"
                             : c.vrw_mps_rth <= 0.035 ? "tactical"
                                                      : "mems";
  const bool bias_seen = c.gyro_bias_min_deg_h > 3.0 * c.gyro_bias_noise_deg_h;
  // Only a bias no box but mems' holds votes (see grade.h); smaller ones are what identify is for.
  const std::string by_bias = bias_seen && c.gyro_bias_min_deg_h > 20.0 ? "mems" : "nav";
  c.grade = by_arw;
  for (const std::string& g : {by_vrw, by_bias})
    if (coarseness(g) > coarseness(c.grade)) c.grade = g;
  c.rule = "grade " + c.grade + " (auto: static window " + number_text(window_s, 3) + " s: ARW " +
           number_text(c.arw_deg_rth, 3) + " deg/sqrt(h) -> " + by_arw + ", VRW " +
           number_text(c.vrw_mps_rth, 3) + " m/s/sqrt(h) -> " + by_vrw +
           ", |gyro bias| >= " + number_text(c.gyro_bias_min_deg_h, 3) + " deg/h (noise " +
           number_text(c.gyro_bias_noise_deg_h, 3) + ") -> " +
           (!bias_seen          ? std::string("not seen")
            : by_bias == "mems" ? std::string("mems")
                                : std::string("no vote (<= 20 deg/h)")) +
           "; the coarsest)";
  return c;
}

nlohmann::json GradeChoice::to_json() const {
  nlohmann::json j;
  j["grade"] = grade;
  j["source"] = source;
  j["rule"] = rule;
  if (std::isfinite(static_window_s)) {
    j["static_window_s"] = static_window_s;
    j["vrw_mps_rth"] = vrw_mps_rth;
    j["gyro_bias_min_deg_h"] = gyro_bias_min_deg_h;
    j["gyro_bias_noise_deg_h"] = gyro_bias_noise_deg_h;
  }
  if (std::isfinite(arw_deg_rth)) j["arw_deg_rth"] = arw_deg_rth;
  return j;
}

const SensorGrade& grade_for(const Dataset& dataset, std::string_view explicit_grade) {
  return sensor_grade(choose_grade(dataset, explicit_grade).grade);
}

double default_window_s(const GradeChoice& choice) { return choice.grade == "mems" ? 10.0 : 0.0; }

nlohmann::json GradeAndWindow::to_json() const {
  return {{"grade_choice", grade.to_json()}, {"window_s_source", window_source}};
}

std::string GradeAndWindow::line() const {
  char w[32];
  std::snprintf(w, sizeof w, "%g", window_s);
  return grade.rule + "; fitness window " +
         (window_s > 0.0 ? std::string(w) + " s" : "0 (one run)") + " (" + window_source + ")";
}

GradeAndWindow settle_grade_and_window(const Dataset& dataset, const std::string& grade_arg,
                                       const std::optional<double>& window_arg) {
  GradeAndWindow g;
  g.grade = choose_grade(dataset, grade_arg);
  if (window_arg) {
    g.window_s = *window_arg;
    g.window_source = "--window-s";
  } else {
    g.window_s = default_window_s(g.grade);
    g.window_source =
        g.window_s > 0.0 ? "default for " + g.grade.grade + " data" : "default: one run";
  }
  return g;
}

}  // namespace insid
