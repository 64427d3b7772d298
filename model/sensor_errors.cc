#include "model/sensor_errors.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>

namespace insid {
namespace {

// Accessor of one effect's storage inside SensorErrors.
using Accessor = std::function<double&(SensorErrors&)>;

struct Entry {
  EffectInfo info;
  Accessor access;
};

int axis_index(char c) { return c == 'x' ? 0 : (c == 'y' ? 1 : 2); }

std::vector<Entry> build_catalogue() {
  std::vector<Entry> out;
  static const char* kAxes[] = {"x", "y", "z"};
  static const char* kPairs[] = {"xy", "xz", "yx", "yz", "zx", "zy"};
  // Names must outlive the string_views: keep them in a static store.
  static std::vector<std::string> names;
  names.reserve(64);
  // The entry being added: its sensor, kind and axes (set before each group of add calls).
  EffectSensor sensor = EffectSensor::kAccel;
  EffectKind kind = EffectKind::kBias;
  int axis = -1, true_axis = -1;
  auto add = [&](std::string name, std::string_view unit, EffectSide side, double sigma,
                 std::string_view description, Accessor access) {
    names.push_back(std::move(name));
    out.push_back({{names.back(), unit, side, sigma, description, sensor, kind, axis, true_axis},
                   std::move(access)});
  };
  const auto term = [&](EffectSensor s, EffectKind k, int i = -1, int j = -1) {
    sensor = s;
    kind = k;
    axis = i;
    true_axis = j;
  };
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kAccel, EffectKind::kBias, i);
    add(std::string("accel_bias_") + a, "m/s^2", EffectSide::kImu, kSigmaAccelMps2,
        "accelerometer zero bias", [i](SensorErrors& e) -> double& { return e.accel.bias[i]; });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kGyro, EffectKind::kBias, i);
    add(std::string("gyro_bias_") + a, "rad/s", EffectSide::kImu, kSigmaGyroRadS,
        "gyro zero bias (drift)", [i](SensorErrors& e) -> double& { return e.gyro.bias[i]; });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kAccel, EffectKind::kScale, i);
    add(std::string("accel_scale_") + a, "1", EffectSide::kImu, 1e-4,
        "accelerometer scale-factor error",
        [i](SensorErrors& e) -> double& { return e.accel.scale[i]; });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kGyro, EffectKind::kScale, i);
    add(std::string("gyro_scale_") + a, "1", EffectSide::kImu, 1e-4, "gyro scale-factor error",
        [i](SensorErrors& e) -> double& { return e.gyro.scale[i]; });
  }
  for (const char* p : kPairs) {
    const int i = axis_index(p[0]), j = axis_index(p[1]);
    term(EffectSensor::kAccel, EffectKind::kMisalign, i, j);
    add(std::string("accel_misalign_") + p, "rad", EffectSide::kImu, 1e-4,
        "accelerometer misalignment (sensor axis i senses true axis j)",
        [i, j](SensorErrors& e) -> double& { return e.accel.misalign(i, j); });
  }
  for (const char* p : kPairs) {
    const int i = axis_index(p[0]), j = axis_index(p[1]);
    term(EffectSensor::kGyro, EffectKind::kMisalign, i, j);
    add(std::string("gyro_misalign_") + p, "rad", EffectSide::kImu, 1e-4,
        "gyro misalignment (sensor axis i senses true axis j)",
        [i, j](SensorErrors& e) -> double& { return e.gyro.misalign(i, j); });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kAccel, EffectKind::kBiasDrift, i);
    add(std::string("accel_bias_drift_") + a, "m/s^3", EffectSide::kImu, kSigmaAccelMps2 / 3600.0,
        "accelerometer bias drift, linear in time from t = 0",
        [i](SensorErrors& e) -> double& { return e.accel.bias_drift[i]; });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kGyro, EffectKind::kBiasDrift, i);
    add(std::string("gyro_bias_drift_") + a, "rad/s^2", EffectSide::kImu, kSigmaGyroRadS / 3600.0,
        "gyro bias drift, linear in time from t = 0",
        [i](SensorErrors& e) -> double& { return e.gyro.bias_drift[i]; });
  }
  term(EffectSensor::kGnss, EffectKind::kLatency);
  add("gnss_latency", "s", EffectSide::kGnss, 0.01,
      "GNSS solution tagged t is the true antenna state at t - latency",
      [](SensorErrors& e) -> double& { return e.gnss_latency_s; });
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kGnss, EffectKind::kLeverArm, i);
    add(std::string("lever_arm_") + a, "m", EffectSide::kGnss, 0.1,
        "GNSS antenna position in b relative to the IMU",
        [i](SensorErrors& e) -> double& { return e.lever_arm_b_m[i]; });
  }
  // Last, so that the catalogue's older entries keep their places in every listing.
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kAccel, EffectKind::kMotorOffset, i);
    add(std::string("accel_motor_offset_") + a, "m/s^2", EffectSide::kImu, kSigmaAccelMps2,
        "accelerometer offset while the motors run (vibration), a step at motor start",
        [i](SensorErrors& e) -> double& { return e.accel.motor_offset[i]; });
  }
  for (const char* a : kAxes) {
    const int i = axis_index(a[0]);
    term(EffectSensor::kGyro, EffectKind::kMotorOffset, i);
    add(std::string("gyro_motor_offset_") + a, "rad/s", EffectSide::kImu, kSigmaGyroRadS,
        "gyro offset while the motors run (vibration), a step at motor start",
        [i](SensorErrors& e) -> double& { return e.gyro.motor_offset[i]; });
  }
  return out;
}

const std::vector<Entry>& entries() {
  static const std::vector<Entry> kEntries = build_catalogue();
  return kEntries;
}

const Entry& find_entry(std::string_view name) {
  for (const Entry& e : entries())
    if (e.info.name == name) return e;
  std::ostringstream msg;
  msg << "unknown effect name '" << name << "'; valid names are:";
  for (const Entry& e : entries()) msg << ' ' << e.info.name;
  throw std::invalid_argument(msg.str());
}

}  // namespace

Eigen::Matrix3d TriadErrors::distortion() const {
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity() + misalign;
  d.diagonal() += scale;
  return d;
}

bool TriadErrors::is_zero() const {
  return bias.isZero(0) && bias_drift.isZero(0) && scale.isZero(0) && misalign.isZero(0) &&
         motor_offset.isZero(0);
}

double MotorSchedule::fraction(double t_begin_s, double t_end_s) const {
  const double length = t_end_s - t_begin_s;
  if (!(length > 0.0)) return 0.0;
  double on = 0.0;
  for (const auto& [t_on, t_off] : on_s) {
    const double overlap = std::min(t_off, t_end_s) - std::max(t_on, t_begin_s);
    if (overlap > 0.0) on += overlap;
  }
  return on >= length ? 1.0 : on / length;
}

std::string MotorSchedule::validate() const {
  for (std::size_t i = 0; i < on_s.size(); ++i) {
    const auto& [t_on, t_off] = on_s[i];
    std::ostringstream msg;
    msg << "motor interval " << i << " (on " << t_on << " s, off " << t_off << " s): ";
    if (!std::isfinite(t_on) || !std::isfinite(t_off)) return msg.str() + "not finite";
    if (!(t_on < t_off)) return msg.str() + "must start before it ends";
    if (i > 0 && !(on_s[i - 1].second <= t_on))
      return msg.str() + "overlaps or precedes the interval before it";
  }
  return "";
}

const std::vector<EffectInfo>& effect_catalogue() {
  static const std::vector<EffectInfo> kInfos = [] {
    std::vector<EffectInfo> infos;
    for (const Entry& e : entries()) infos.push_back(e.info);
    return infos;
  }();
  return kInfos;
}

const EffectInfo& effect_info(std::string_view name) { return find_entry(name).info; }

const EffectInfo* find_effect_info(std::string_view name) {
  for (const Entry& e : entries())
    if (e.info.name == name) return &e.info;
  return nullptr;
}

const EffectInfo& effect_info(EffectSensor sensor, EffectKind kind, int axis, int true_axis) {
  for (const Entry& e : entries())
    if (e.info.sensor == sensor && e.info.kind == kind && e.info.axis == axis &&
        e.info.true_axis == true_axis)
      return e.info;
  throw std::invalid_argument("the effect catalogue has no effect of sensor " +
                              std::to_string(static_cast<int>(sensor)) + ", kind " +
                              std::to_string(static_cast<int>(kind)) + ", axes " +
                              std::to_string(axis) + ", " + std::to_string(true_axis));
}

bool is_effect_name(std::string_view name) { return find_effect_info(name) != nullptr; }

double get_effect(const SensorErrors& errors, std::string_view name) {
  SensorErrors copy = errors;
  return find_entry(name).access(copy);
}

void set_effect(SensorErrors& errors, std::string_view name, double value) {
  if (!std::isfinite(value))
    throw std::invalid_argument("effect '" + std::string(name) + "' must be a finite number");
  find_entry(name).access(errors) = value;
}

void add_effect(SensorErrors& errors, std::string_view name, double value) {
  set_effect(errors, name, get_effect(errors, name) + value);
}

SensorErrors errors_from_map(const std::map<std::string, double>& values) {
  SensorErrors errors;
  for (const auto& [name, value] : values) set_effect(errors, name, value);
  return errors;
}

std::map<std::string, double> nonzero_effects(const SensorErrors& errors) {
  std::map<std::string, double> out;
  SensorErrors copy = errors;
  for (const Entry& e : entries()) {
    const double v = e.access(copy);
    if (v != 0.0) out[std::string(e.info.name)] = v;
  }
  return out;
}

void apply_imu_errors(const SensorErrors& errors, double t_s, double dt_s,
                      Eigen::Vector3d& dtheta_b, Eigen::Vector3d& dv_b, double motor_on) {
  const double t_mid = t_s - 0.5 * dt_s;
  dtheta_b = errors.gyro.distortion() * dtheta_b +
             (errors.gyro.bias + errors.gyro.bias_drift * t_mid) * dt_s;
  dv_b = errors.accel.distortion() * dv_b +
         (errors.accel.bias + errors.accel.bias_drift * t_mid) * dt_s;
  if (motor_on != 0.0) {
    dtheta_b += errors.gyro.motor_offset * (motor_on * dt_s);
    dv_b += errors.accel.motor_offset * (motor_on * dt_s);
  }
}

ImuCompensator::ImuCompensator(const SensorErrors& errors)
    : gyro_(errors.gyro),
      accel_(errors.accel),
      gyro_inv_(errors.gyro.distortion().inverse()),
      accel_inv_(errors.accel.distortion().inverse()) {}

void ImuCompensator::compensate(double t_s, double dt_s, Eigen::Vector3d& dtheta_b,
                                Eigen::Vector3d& dv_b, double motor_on) const {
  const double t_mid = t_s - 0.5 * dt_s;
  // Without a motor part the bias is b0 + b_dot t_mid exactly, the form the batch kernel's fast
  // path reproduces bit for bit.
  if (motor_on == 0.0) {
    dtheta_b = gyro_inv_ * (dtheta_b - (gyro_.bias + gyro_.bias_drift * t_mid) * dt_s);
    dv_b = accel_inv_ * (dv_b - (accel_.bias + accel_.bias_drift * t_mid) * dt_s);
    return;
  }
  dtheta_b =
      gyro_inv_ *
      (dtheta_b - (gyro_.bias + gyro_.bias_drift * t_mid + gyro_.motor_offset * motor_on) * dt_s);
  dv_b = accel_inv_ *
         (dv_b - (accel_.bias + accel_.bias_drift * t_mid + accel_.motor_offset * motor_on) * dt_s);
}

void ImuCompensator::compensate_mean(double t_mid_mean_s, Eigen::Vector3d& omega_ib_b,
                                     Eigen::Vector3d& f_ib_b, double motor_on_mean) const {
  omega_ib_b = gyro_inv_ * (omega_ib_b - (gyro_.bias + gyro_.bias_drift * t_mid_mean_s +
                                          gyro_.motor_offset * motor_on_mean));
  f_ib_b = accel_inv_ * (f_ib_b - (accel_.bias + accel_.bias_drift * t_mid_mean_s +
                                   accel_.motor_offset * motor_on_mean));
}

double ImuCompensator::projected_gyro_sum(const Eigen::Matrix3d& sum_u_dtheta,
                                          const Eigen::Vector3d& sum_u_dt,
                                          const Eigen::Vector3d& sum_u_tmid_dt,
                                          const Eigen::Vector3d& sum_u_motor_dt) const {
  // sum_k u_k^T G^-1 dtheta_k = sum_ij (G^-1)_ij (sum_k u_k,i dtheta_k,j).
  return gyro_inv_.cwiseProduct(sum_u_dtheta).sum() - sum_u_dt.dot(gyro_inv_ * gyro_.bias) -
         sum_u_tmid_dt.dot(gyro_inv_ * gyro_.bias_drift) -
         sum_u_motor_dt.dot(gyro_inv_ * gyro_.motor_offset);
}

}  // namespace insid
