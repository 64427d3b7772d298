// Static coarse alignment: levelling from the mean specific force and gyrocompassing from the
// mean angular rate (analytic / TRIAD form, e.g. Groves 2013 sec. 5.6). Re-aligning for a
// different candidate error costs O(1): the window sums are taken once from the measured data
// and the (affine) error model is inverted on the window means.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "core/dataset.h"
#include "core/sensor_errors.h"

namespace insid {

/// Sums over the alignment window of measured increments (computed once per dataset).
struct AlignmentWindow {
  Eigen::Vector3d sum_dtheta_b = Eigen::Vector3d::Zero();  ///< (rad)
  Eigen::Vector3d sum_dv_b = Eigen::Vector3d::Zero();      ///< (m/s)
  double sum_dt_s = 0.0;
  double mean_t_mid_s = 0.0;  ///< dt-weighted mean of the samples' mid-times (for bias drifts)
  std::size_t count = 0;

  /// Window over imu[begin, end); the first sample's interval starts at t_start_s.
  static AlignmentWindow from_imu(const std::vector<ImuSample>& imu, std::size_t begin,
                                  std::size_t end, double t_start_s);
};

/// C_b_n from mean specific force f_ib_b (m/s^2) and mean angular rate omega_ib_b (rad/s) of a
/// stationary IMU. Throws std::invalid_argument when the vectors are (nearly) parallel or zero.
Eigen::Matrix3d coarse_align(const Eigen::Vector3d& f_ib_b, const Eigen::Vector3d& omega_ib_b);

/// C_b_n for a candidate error model, in O(1) from the precomputed window sums.
Eigen::Matrix3d align_window(const AlignmentWindow& window, const ImuCompensator& compensator);

}  // namespace insid
