#include "nav/gyro_at_rest.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

#include "base/number_text.h"

namespace insid {

bool measured_at_rest(std::string_view effect_name) {
  const EffectInfo* info = find_effect_info(effect_name);
  return info != nullptr && info->sensor == EffectSensor::kGyro && info->kind == EffectKind::kBias;
}

GyroAtRest gyro_at_rest(const NavigationProblem& navigation) {
  const AlignmentWindow& window = navigation.alignment_window();
  const Dataset& dataset = navigation.dataset();
  if (window.count == 0 || !(window.sum_dt_s > 0.0))
    throw std::invalid_argument(
        "the gyro bias at rest needs a static window, and the dataset has align_s = " +
        number_text(dataset.meta.align_s, 12) + " s");
  if (window.mean_motor_on > 0.0)
    throw std::invalid_argument(
        "the gyro bias at rest needs a window with the motors off, and they ran " +
        number_text(100.0 * window.mean_motor_on, 3) +
        " % of the alignment window (align_s = " + number_text(dataset.meta.align_s, 12) +
        " s): give a shorter align_s (an import's --align-s) that ends before the motor start");
  if (navigation.options().initial_attitude.mode == InitialAttitudeMode::kGyrocompass)
    throw std::invalid_argument(
        "the gyro bias at rest cannot be measured when the heading comes from gyrocompassing: "
        "both read the static window's rate (choose --initial-attitude level+heading or given)");
  GyroAtRest rest;
  rest.mean_omega_ib_b = window.sum_dtheta_b / window.sum_dt_s;
  const Eigen::Matrix3d C_b_n = navigation.initial_attitude(SensorErrors{});
  rest.omega_ie_b = C_b_n.transpose() * dataset.meta.earth.omega_ie_n(dataset.meta.initial.lat_rad);
  rest.t_mid_s = window.mean_t_mid_s;
  rest.motor_on_mean = window.mean_motor_on;
  rest.t_end_s = dataset.imu[navigation.nav_begin() - 1].t_s;
  rest.t_begin_s = rest.t_end_s - window.sum_dt_s;
  rest.samples = window.count;
  Eigen::Vector3d sum_sq = Eigen::Vector3d::Zero();
  double t_prev = rest.t_begin_s;
  std::size_t used = 0;
  for (std::size_t k = navigation.nav_begin() - window.count; k < navigation.nav_begin(); ++k) {
    const double dt = dataset.imu[k].t_s - t_prev;
    t_prev = dataset.imu[k].t_s;
    if (!(dt > 0.0)) continue;
    sum_sq += (dataset.imu[k].dtheta_b_rad / dt - rest.mean_omega_ib_b).cwiseAbs2();
    ++used;
  }
  if (used > 1)
    rest.sd_of_mean_rad_s =
        (sum_sq / static_cast<double>(used - 1)).cwiseSqrt() / std::sqrt(static_cast<double>(used));
  return rest;
}

}  // namespace insid
