// The sensor grades' figures, in one table: the one-sigma size of each IMU error and
// the white-noise levels of a navigation-grade, tactical-grade and MEMS IMU with its GNSS, in
// physical units. Read by the estimation grades (identification/grade.h: the search unit of
// every effect), the simulator's noise grades (scenarios/noise.cc: the noise it adds) and the
// window study (identification/window_study.h: its sigmas and injected biases), which each
// wrote these numbers themselves before.
//
//   grade     gyro bias    accel bias   scale / misalign   ARW (deg/sqrt(h)) VRW (m/s/sqrt(h))
//   nav       0.01 deg/h   0.0005 m/s^2 1e-4 / 1e-4 rad    0.002             0.001
//   tactical  1 deg/h      1 mg         3e-4 / 3e-4 rad    0.05              0.02
//   mems      0.1 deg/s    10 mg        1e-3 / 1e-3 rad    0.2               0.05
//
// GNSS white noise per ENU axis: nav 0.01 m/s / 0.02 m (an RTK-class receiver), tactical
// 0.02 m/s / 0.1 m, mems 0.03 m/s / 0.5 m. nav's error sizes are the effect catalogue's
// (model/sensor_errors.h, the paper's); nav's and mems' noise are the simulator's; tactical's are
// typical FOG / high-end-MEMS figures (no simulator grade uses them).
//
// Physical limits: the largest size a unit of the grade can have, with where it comes
// from. An identification widens a box whose estimate sits at its edge up to these, never beyond
// (identification/identify_run.h); an estimate or a named effect beyond them is flagged as not
// physical for the grade.
//   mems      gyro bias 20 deg/s, accel bias 80 mg, scale 3 %, misalignment 2 % (0.02 rad): the
//             initial tolerances of the InvenSense MPU-6000/6050 datasheet (PS-MPU-6000A-00 rev.
//             3.4, sec. 6.1-6.2: ZRO +-20 deg/s, zero-g +-50 mg x/y and +-80 mg z, sensitivity
//             +-3 %, cross-axis +-2 %), the drone autopilots' IMU of that class.
//   nav, tactical  ten times the grade's one sigma (no datasheet range stands for every unit of
//             these grades; a unit ten sigma off is not of its grade).
// Bias drifts: the bias limit per hour (sigma's convention: one sigma of drift per hour).
#pragma once

#include <span>
#include <string_view>

#include "data/dataset.h"

namespace insid {

struct GradeFigures {
  std::string_view name;         ///< "nav" | "tactical" | "mems"
  double gyro_bias_rad_s = 0.0;  ///< one sigma of a gyro bias (rad/s)
  double accel_bias_mps2 = 0.0;  ///< one sigma of an accelerometer bias (m/s^2)
  double scale = 0.0;            ///< one sigma of a scale-factor error (1)
  double misalign_rad = 0.0;     ///< one sigma of a misalignment (rad)
  NoiseLevels noise;             ///< white noise: ARW, VRW, GNSS velocity and position
  /// The largest physical size of each error (SI, the same units as the sigmas above) and where
  /// the figures come from (the table at the top).
  double gyro_bias_limit_rad_s = 0.0;
  double accel_bias_limit_mps2 = 0.0;
  double scale_limit = 0.0;
  double misalign_limit_rad = 0.0;
  std::string_view limit_source;
};

/// nav, tactical, mems, in this order (coarser last).
std::span<const GradeFigures> grade_table();

/// The row named `name`; throws std::invalid_argument naming the value and the valid names.
const GradeFigures& grade_figures(std::string_view name);

}  // namespace insid
