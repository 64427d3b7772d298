#include "model/rotation.h"

#include <algorithm>
#include <cmath>

namespace insid {

Eigen::Matrix3d C_b_n_from_euler(const EulerAngles& e) {
  // Standard aerospace 3-2-1 sequence gives C_b_ned; then swap NED -> ENU.
  const double cr = std::cos(e.roll_rad), sr = std::sin(e.roll_rad);
  const double cp = std::cos(e.pitch_rad), sp = std::sin(e.pitch_rad);
  const double cy = std::cos(e.yaw_rad), sy = std::sin(e.yaw_rad);
  Eigen::Matrix3d C_b_ned;
  C_b_ned << cp * cy, -cr * sy + sr * sp * cy, sr * sy + cr * sp * cy,  //
      cp * sy, cr * cy + sr * sp * sy, -sr * cy + cr * sp * sy,         //
      -sp, sr * cp, cr * cp;
  return C_ned_enu() * C_b_ned;
}

EulerAngles euler_from_C_b_n(const Eigen::Matrix3d& C_b_n) {
  const Eigen::Matrix3d C_b_ned = C_ned_enu() * C_b_n;
  EulerAngles e;
  e.roll_rad = std::atan2(C_b_ned(2, 1), C_b_ned(2, 2));
  e.pitch_rad = std::asin(std::clamp(-C_b_ned(2, 0), -1.0, 1.0));
  e.yaw_rad = std::atan2(C_b_ned(1, 0), C_b_ned(0, 0));
  return e;
}

Eigen::Quaterniond q_b_n_from_euler(const EulerAngles& e) {
  Eigen::Quaterniond q(C_b_n_from_euler(e));
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return q;
}

EulerAngles euler_from_q_b_n(const Eigen::Quaterniond& q_b_n) {
  return euler_from_C_b_n(q_b_n.normalized().toRotationMatrix());
}

Eigen::Quaterniond quat_from_rotation_vector(const Eigen::Vector3d& phi_rad) {
  const double angle = phi_rad.norm();
  const double half = 0.5 * angle;
  // sin(x/2)/x, with its series for small angles.
  const double k = angle < 1e-8 ? 0.5 - angle * angle / 48.0 : std::sin(half) / angle;
  return Eigen::Quaterniond(std::cos(half), k * phi_rad.x(), k * phi_rad.y(), k * phi_rad.z());
}

Eigen::Vector3d rotation_vector_from_quat(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() *= -1.0;
  const double s = q.vec().norm();
  const double angle = 2.0 * std::atan2(s, q.w());
  if (s < 1e-12) return 2.0 * q.vec();
  return q.vec() * (angle / s);
}

double wrap_pi(double angle_rad) {
  double a = std::remainder(angle_rad, 2.0 * kPi);
  if (a <= -kPi) a += 2.0 * kPi;
  return a;
}

double wrap_two_pi(double angle_rad) {
  double a = std::fmod(angle_rad, 2.0 * kPi);
  if (a < 0) a += 2.0 * kPi;
  if (a >= 2.0 * kPi) a -= 2.0 * kPi;
  return a;
}

}  // namespace insid
