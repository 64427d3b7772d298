#include "identification/grade.h"

#include <cmath>
#include <stdexcept>

#include "core/rotation.h"

namespace insid {
namespace {

constexpr double kG0 = 9.80665;  // standard gravity: 1 mg = 9.80665e-3 m/s^2

const std::vector<SensorGrade>& grades() {
  static const std::vector<SensorGrade> kGrades = {
      {"nav", kSigmaGyroRadS, kSigmaAccelMps2, 1e-4, 1e-4, {0.002, 0.001, 0.01, 0.02}},
      {"tactical", 1.0 * kDegToRad / 3600.0, 1e-3 * kG0, 3e-4, 3e-4, {0.05, 0.02, 0.02, 0.1}},
      {"mems", 0.1 * kDegToRad, 10e-3 * kG0, 1e-3, 1e-3, {0.2, 0.05, 0.03, 0.5}},
  };
  return kGrades;
}

bool starts_with(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

}  // namespace

double SensorGrade::sigma(std::string_view effect) const {
  const EffectInfo& info = effect_info(effect);  // throws on an unknown name
  if (info.side == EffectSide::kGnss) return info.sigma;
  if (starts_with(effect, "gyro_bias_drift_")) return gyro_bias_rad_s / 3600.0;
  if (starts_with(effect, "accel_bias_drift_")) return accel_bias_mps2 / 3600.0;
  if (starts_with(effect, "gyro_bias_")) return gyro_bias_rad_s;
  if (starts_with(effect, "accel_bias_")) return accel_bias_mps2;
  if (effect.find("_scale_") != std::string_view::npos) return scale;
  if (effect.find("_misalign_") != std::string_view::npos) return misalign_rad;
  throw std::logic_error("grade '" + name + "': no sigma for effect '" + std::string(effect) + "'");
}

EstimatedParameter SensorGrade::parameter(const std::string& text) const {
  EstimatedParameter p = EstimatedParameter::parse(text);
  if (text.find(':') == std::string::npos) p.sigma = sigma(p.name);
  return p;
}

std::vector<EstimatedParameter> default_estimated(const SensorGrade& grade) {
  if (grade.name == "nav") return EstimatedParameter::paper_four();
  std::vector<EstimatedParameter> out;
  for (const char* name :
       {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y", "gyro_bias_z"})
    out.push_back(grade.parameter(name));
  return out;
}

const SensorGrade& sensor_grade(std::string_view name) {
  for (const SensorGrade& g : grades())
    if (g.name == name) return g;
  throw std::invalid_argument("unknown sensor grade '" + std::string(name) +
                              "'; valid grades are: nav, tactical, mems");
}

std::vector<std::string> sensor_grade_names() {
  std::vector<std::string> out;
  for (const SensorGrade& g : grades()) out.push_back(g.name);
  return out;
}

std::optional<std::string> declared_grade(const Dataset& dataset) {
  if (!dataset.meta.noise) return std::nullopt;
  const double arw = dataset.meta.noise->arw_deg_rth;
  if (arw <= 0.01) return "nav";
  if (arw <= 0.1) return "tactical";
  return "mems";
}

const SensorGrade& grade_for(const Dataset& dataset, std::string_view explicit_grade) {
  if (!explicit_grade.empty() && explicit_grade != "auto") return sensor_grade(explicit_grade);
  return sensor_grade(declared_grade(dataset).value_or("nav"));
}

}  // namespace insid
