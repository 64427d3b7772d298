// Attitude conventions (docs/design.md sec. 3): b = FRD body, n = ENU. C_b_n maps b to n
// (v_n = C_b_n * v_b). Euler angles: roll (right wing down +), pitch (nose up +),
// yaw = heading from north, clockwise + (all in radians here; degrees only at I/O).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "model/units.h"  // kPi, kDegToRad, kRadToDeg (included by many through this header)

namespace insid {

struct EulerAngles {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

/// NED <-> ENU axis swap (its own inverse).
inline Eigen::Matrix3d C_ned_enu() {
  Eigen::Matrix3d c;
  c << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return c;
}

/// Skew-symmetric (cross-product) matrix: skew(a) * b = a x b.
inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d s;
  s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return s;
}

/// C_b_n (b = FRD to n = ENU) from Euler angles.
Eigen::Matrix3d C_b_n_from_euler(const EulerAngles& e);
/// Euler angles from C_b_n; yaw in (-pi, pi].
EulerAngles euler_from_C_b_n(const Eigen::Matrix3d& C_b_n);
/// Quaternion q_b_n (v_n = q_b_n * v_b) from Euler angles.
Eigen::Quaterniond q_b_n_from_euler(const EulerAngles& e);
/// Euler angles from q_b_n.
EulerAngles euler_from_q_b_n(const Eigen::Quaterniond& q_b_n);
/// Unit quaternion of a rotation vector (angle-axis), exact for any angle.
Eigen::Quaterniond quat_from_rotation_vector(const Eigen::Vector3d& phi_rad);
/// Rotation vector of a unit quaternion (angle in [0, pi]).
Eigen::Vector3d rotation_vector_from_quat(const Eigen::Quaterniond& q);
/// Wrap an angle to (-pi, pi].
double wrap_pi(double angle_rad);
/// Wrap an angle to [0, 2 pi).
double wrap_two_pi(double angle_rad);

}  // namespace insid
