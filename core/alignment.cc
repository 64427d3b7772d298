#include "core/alignment.h"

#include <stdexcept>

namespace insid {

AlignmentWindow AlignmentWindow::from_imu(const std::vector<ImuSample>& imu, std::size_t begin,
                                          std::size_t end, double t_start_s) {
  if (begin >= end || end > imu.size())
    throw std::invalid_argument("alignment window is empty or out of range");
  AlignmentWindow w;
  double sum_t_mid_dt = 0.0;
  double t_prev = t_start_s;
  for (std::size_t k = begin; k < end; ++k) {
    const double dt = imu[k].t_s - t_prev;
    w.sum_dtheta_b += imu[k].dtheta_b_rad;
    w.sum_dv_b += imu[k].dv_b_mps;
    w.sum_dt_s += dt;
    sum_t_mid_dt += (imu[k].t_s - 0.5 * dt) * dt;
    t_prev = imu[k].t_s;
  }
  w.count = end - begin;
  w.mean_t_mid_s = sum_t_mid_dt / w.sum_dt_s;
  return w;
}

Eigen::Matrix3d coarse_align(const Eigen::Vector3d& f_ib_b, const Eigen::Vector3d& omega_ib_b) {
  // A static IMU senses f_n = (0, 0, g) (up) and omega_ie_n = (0, W cos lat, W sin lat).
  // In n: omega x f is east, f is up, up x east is north. The same constructions in b give the
  // n axes expressed in b, i.e. the columns of C_n_b = C_b_n^T (analytic coarse alignment).
  const double f_norm = f_ib_b.norm();
  if (!(f_norm > 0.0)) throw std::invalid_argument("coarse alignment: zero specific force");
  const Eigen::Vector3d up_b = f_ib_b / f_norm;
  const Eigen::Vector3d east_raw_b = omega_ib_b.cross(up_b);
  const double east_norm = east_raw_b.norm();
  if (!(east_norm > 1e-3 * omega_ib_b.norm()) || !(east_norm > 0.0))
    throw std::invalid_argument(
        "coarse alignment: angular rate parallel to specific force (at a pole?)");
  const Eigen::Vector3d east_b = east_raw_b / east_norm;
  const Eigen::Vector3d north_b = up_b.cross(east_b);
  Eigen::Matrix3d C_b_n;
  C_b_n.row(0) = east_b.transpose();
  C_b_n.row(1) = north_b.transpose();
  C_b_n.row(2) = up_b.transpose();
  return C_b_n;
}

Eigen::Matrix3d align_window(const AlignmentWindow& window, const ImuCompensator& compensator) {
  Eigen::Vector3d omega_ib_b = window.sum_dtheta_b / window.sum_dt_s;
  Eigen::Vector3d f_ib_b = window.sum_dv_b / window.sum_dt_s;
  compensator.compensate_mean(window.mean_t_mid_s, omega_ib_b, f_ib_b);
  return coarse_align(f_ib_b, omega_ib_b);
}

}  // namespace insid
