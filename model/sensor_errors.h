// Sensor error model and the one catalogue of effect names (docs/design.md sec. 3-4).
//
// IMU model, measured from true (docs/design.md sec. 3):
//   m = (I + S + M) * true + b(t) + noise,   b(t) = b0 + b_dot * t + b_motor * u(t),
// S diagonal scale factors, M off-diagonal misalignments (M(i,j): sensor axis i sensing true
// axis j), u(t) = 1 while the motors run and 0 otherwise (MotorSchedule: the offset vibration
// adds to a MEMS sensor's zero, a step at motor start). For increments over (t - dt, t] the
// bias integrates to
//   b0 * dt + b_dot * (t - dt / 2) * dt + b_motor * (the part of dt the motors ran).
// Compensation inverts the model exactly. GNSS-side effects: the GNSS solution tagged t is the
// true antenna state at t - latency; the antenna sits at lever_arm_b from the IMU.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

namespace insid {

/// Errors of one IMU triad (gyro or accelerometer), SI units.
struct TriadErrors {
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();        ///< b0 (rad/s or m/s^2)
  Eigen::Vector3d bias_drift = Eigen::Vector3d::Zero();  ///< b_dot (rad/s^2 or m/s^3)
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();       ///< diag(S) (1)
  Eigen::Matrix3d misalign = Eigen::Matrix3d::Zero();    ///< M, zero diagonal (rad)
  /// b_motor: added to the bias while the motors run (rad/s or m/s^2)
  Eigen::Vector3d motor_offset = Eigen::Vector3d::Zero();

  /// I + S + M.
  Eigen::Matrix3d distortion() const;
  bool is_zero() const;
};

struct SensorErrors {
  TriadErrors gyro;
  TriadErrors accel;
  double gnss_latency_s = 0.0;                              ///< GNSS tag minus true time (s)
  Eigen::Vector3d lever_arm_b_m = Eigen::Vector3d::Zero();  ///< antenna in b from IMU (m)
};

enum class EffectSide { kImu, kGnss };
/// The instrument an effect belongs to.
enum class EffectSensor { kGyro, kAccel, kGnss };
/// The term of the error model it is: b0, b_dot, diag(S), M, b_motor (IMU); the latency and the
/// lever arm (GNSS).
enum class EffectKind { kBias, kBiasDrift, kScale, kMisalign, kMotorOffset, kLatency, kLeverArm };

/// When the motors run, in the dataset's time (s): half-open intervals [on, off), sorted and
/// disjoint (DatasetMeta::motors; an importer reads them from the autopilot's motor outputs, a
/// simulation from its scenario). Empty: no motor state known, and the motor offsets do nothing.
struct MotorSchedule {
  std::vector<std::pair<double, double>> on_s;  ///< (on, off) pairs
  bool empty() const { return on_s.empty(); }
  /// The part of (t_begin_s, t_end_s] the motors ran, as a fraction of its length (0 when the
  /// interval is empty): u averaged over an IMU increment.
  double fraction(double t_begin_s, double t_end_s) const;
  /// "" when the intervals are finite, each on < off, sorted and disjoint; else the first bad
  /// interval, named by its index and values.
  std::string validate() const;
};

/// One entry of the effect catalogue. Its name is for files and people: code decides by the
/// typed fields (sensor, kind, axes), never by parts of the name.
struct EffectInfo {
  std::string_view name;  ///< catalogue name, never renamed
  std::string_view unit;  ///< SI unit of the value
  EffectSide side;
  double sigma;  ///< typical size used as the search/scale unit (SI)
  std::string_view description;
  EffectSensor sensor = EffectSensor::kGnss;
  EffectKind kind = EffectKind::kLatency;
  int axis = -1;       ///< 0, 1, 2 for x, y, z (a misalignment's sensor axis i); -1 for none
  int true_axis = -1;  ///< a misalignment's true axis j (M(i, j)); -1 otherwise
};

/// The whole catalogue, in a fixed order.
const std::vector<EffectInfo>& effect_catalogue();
/// Entry by name; throws std::invalid_argument listing valid names when unknown.
const EffectInfo& effect_info(std::string_view name);
/// Entry by name; nullptr when the name is not in the catalogue.
const EffectInfo* find_effect_info(std::string_view name);
/// The entry of one sensor's term on one axis (a misalignment also names its true axis);
/// throws std::invalid_argument when the catalogue has no such effect.
const EffectInfo& effect_info(EffectSensor sensor, EffectKind kind, int axis = -1,
                              int true_axis = -1);
bool is_effect_name(std::string_view name);

/// Read / write one effect's value (SI) by catalogue name. Throw on an unknown name.
double get_effect(const SensorErrors& errors, std::string_view name);
void set_effect(SensorErrors& errors, std::string_view name, double value);
/// Add `value` to the effect (used to stack --set on top of a preset).
void add_effect(SensorErrors& errors, std::string_view name, double value);

/// Errors from {name: value}; throws on unknown names or non-finite values.
SensorErrors errors_from_map(const std::map<std::string, double>& values);
/// Non-zero effects as {name: value}.
std::map<std::string, double> nonzero_effects(const SensorErrors& errors);

/// Paper sigma units (docs/design.md sec. 2).
constexpr double kSigmaAccelMps2 = 0.0005;  // sigma_A = 0.0005 m/s^2
constexpr double kSigmaGyroRadS = 0.01 * 3.14159265358979323846 / 180.0 / 3600.0;  // 0.01 deg/h

/// Apply the IMU error model to one pair of true increments over (t_s - dt_s, t_s]; `motor_on`
/// is the part of the step the motors ran (MotorSchedule::fraction).
void apply_imu_errors(const SensorErrors& errors, double t_s, double dt_s,
                      Eigen::Vector3d& dtheta_b, Eigen::Vector3d& dv_b, double motor_on = 0.0);

/// Precomputed inverse of the IMU error model (compensation), cheap per sample.
class ImuCompensator {
 public:
  explicit ImuCompensator(const SensorErrors& errors);
  /// Compensate measured increments over (t_s - dt_s, t_s] in place; `motor_on` as for
  /// apply_imu_errors.
  void compensate(double t_s, double dt_s, Eigen::Vector3d& dtheta_b, Eigen::Vector3d& dv_b,
                  double motor_on = 0.0) const;
  /// Compensate the mean rate / specific force of a window whose sample mid-times average
  /// to t_mid_mean_s and whose motor state averages to motor_on_mean (the model is affine, so
  /// this is exact for window means).
  void compensate_mean(double t_mid_mean_s, Eigen::Vector3d& omega_ib_b, Eigen::Vector3d& f_ib_b,
                       double motor_on_mean = 0.0) const;
  /// sum_k u_k^T G^-1 (dtheta_k - (b0 + b_dot t_mid_k + b_motor m_k) dt_k): compensated gyro
  /// increments projected on directions u_k, in O(1) from sum u dtheta^T, sum u dt, sum u t_mid
  /// dt and sum u m dt (m_k the motor part of step k; the model is affine; level+heading carries
  /// a course back with it, nav/alignment.h).
  double projected_gyro_sum(const Eigen::Matrix3d& sum_u_dtheta, const Eigen::Vector3d& sum_u_dt,
                            const Eigen::Vector3d& sum_u_tmid_dt,
                            const Eigen::Vector3d& sum_u_motor_dt = Eigen::Vector3d::Zero()) const;

 private:
  TriadErrors gyro_, accel_;
  Eigen::Matrix3d gyro_inv_, accel_inv_;
};

}  // namespace insid
