#include "diagnose/advice.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "model/sensor_errors.h"

namespace insid::diagnose {

std::string effect_kind(const std::string& name) {
  const EffectInfo* info = find_effect_info(name);
  if (info == nullptr) return "other";
  const char* sensor = info->sensor == EffectSensor::kGyro ? "gyro_" : "accel_";
  switch (info->kind) {
    case EffectKind::kBias:
      return std::string(sensor) + "bias";
    case EffectKind::kBiasDrift:
      return std::string(sensor) + "drift";
    case EffectKind::kScale:
      return std::string(sensor) + "scale";
    case EffectKind::kMisalign:
      return std::string(sensor) + "misalign";
    case EffectKind::kMotorOffset:
      return std::string(sensor) + "motor";
    case EffectKind::kLatency:
      return "latency";
    case EffectKind::kLeverArm:
      return "lever_arm";
  }
  return "other";
}

std::string separating_manoeuvre(const std::string& a, const std::string& b) {
  std::string ka = effect_kind(a), kb = effect_kind(b);
  if (ka > kb) std::swap(ka, kb);
  auto is = [&](const char* x, const char* y) { return ka == x && kb == y; };
  auto accel_side = [](const std::string& k) {
    return k == "accel_bias" || k == "accel_scale" || k == "accel_misalign" || k == "accel_drift";
  };
  auto gyro_side = [](const std::string& k) {
    return k == "gyro_bias" || k == "gyro_scale" || k == "gyro_misalign" || k == "gyro_drift";
  };
  if (is("latency", "lever_arm"))
    return "speed changes (along-track accelerations) and turns flown at different speeds: the "
           "latency term scales with acceleration, the lever-arm term with rotation rate only";
  if (is("lever_arm", "lever_arm"))
    return "rotations about different body axes: turns (yaw) for the horizontal lever-arm "
           "components, roll and pitch changes (banking in and out, climbs) for the vertical one";
  if (ka == "latency" || kb == "latency")
    return "speed changes both ways (accelerate and decelerate) and turns both ways: latency "
           "follows the instantaneous acceleration and vanishes in steady flight";
  if (ka == "lever_arm" || kb == "lever_arm")
    return "turns both ways at different rates, and roll/pitch changes: a lever arm acts only "
           "while the body rotates";
  const auto motor = [](const std::string& k) { return k == "accel_motor" || k == "gyro_motor"; };
  if (motor(ka) || motor(kb))
    return "navigation with the motors off as well as on (on the ground before the motor start: "
           "end the static window earlier with --align-s): a motor offset steps at motor start, "
           "the other terms do not";
  if ((ka == "accel_bias" && kb == "accel_drift") || (ka == "gyro_bias" && kb == "gyro_drift"))
    return "a longer flight, with reciprocal headings flown late as well as early: a drift grows "
           "linearly in time, a constant bias does not";
  if (is("gyro_bias", "gyro_scale") || is("gyro_drift", "gyro_scale"))
    return "turns in both directions and at different rates: a scale factor acts only while "
           "turning and changes sign with the turn direction, a bias acts all the time";
  if (is("accel_bias", "accel_scale") || is("accel_drift", "accel_scale"))
    return "speed changes in both directions and reciprocal headings: a scale factor follows the "
           "specific force, a bias does not";
  if (accel_side(ka) && accel_side(kb))
    return "heading reversals (reciprocal legs) and climbs/banked turns that change the specific "
           "force along each body axis: biases turn with the heading, tilt-like terms with the "
           "attitude";
  if (gyro_side(ka) && gyro_side(kb))
    return "turns both ways at different rates plus roll/pitch manoeuvres: they separate rotation "
           "about each body axis";
  if ((accel_side(ka) && gyro_side(kb)) || (gyro_side(ka) && accel_side(kb)))
    return "heading reversals (reciprocal legs) and turns: a tilt from a gyro error and an "
           "accelerometer error project differently on the reciprocal heading";
  return "a flight that excites each effect separately: reciprocal headings, turns both ways at "
         "different rates, speed changes and climbs";
}

const std::vector<std::string>& phase_names() {
  static const std::vector<std::string> kNames = {"straight", "turn", "speed change",
                                                  "climb/descent", "slow"};
  return kNames;
}

std::vector<std::string> flight_phases(const std::vector<GnssSample>& gnss) {
  const std::size_t n = gnss.size();
  std::vector<std::string> out(n, "straight");
  if (n < 3) return out;
  std::size_t lo = 0, hi = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = gnss[k].t_s;
    while (gnss[lo].t_s < t - 1.0 && lo < k) ++lo;
    while (hi + 1 < n && gnss[hi + 1].t_s <= t + 1.0) ++hi;
    const GnssSample& g = gnss[k];
    const double speed = std::hypot(g.v_eb_n_mps.x(), g.v_eb_n_mps.y());
    if (speed < 3.0) {
      out[k] = "slow";
      continue;
    }
    const std::size_t a = std::min(lo, k), b = std::max(hi, k);
    const double dt = gnss[b].t_s - gnss[a].t_s;
    double course_rate = 0.0, accel = 0.0;
    if (dt > 0.0) {
      const auto& va = gnss[a].v_eb_n_mps;
      const auto& vb = gnss[b].v_eb_n_mps;
      double dc = std::atan2(vb.x(), vb.y()) - std::atan2(va.x(), va.y());
      while (dc > std::numbers::pi) dc -= 2.0 * std::numbers::pi;
      while (dc < -std::numbers::pi) dc += 2.0 * std::numbers::pi;
      course_rate = dc / dt;
      accel = (std::hypot(vb.x(), vb.y()) - std::hypot(va.x(), va.y())) / dt;
    }
    if (std::abs(course_rate) > 2.0 * std::numbers::pi / 180.0)
      out[k] = "turn";
    else if (std::abs(accel) > 0.2)
      out[k] = "speed change";
    else if (std::abs(g.v_eb_n_mps.z()) > 0.5)
      out[k] = "climb/descent";
  }
  return out;
}

}  // namespace insid::diagnose
