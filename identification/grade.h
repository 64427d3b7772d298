// Sensor grades (issue 14): the search unit (sigma) of every catalogue effect and the noise
// levels of a navigation-grade, tactical-grade and MEMS IMU, in physical units. The effect
// catalogue (core/sensor_errors.h) holds the paper's navigation-grade sigmas (0.01 deg/h,
// 0.0005 m/s^2); a MEMS gyro bias of 0.1-1 deg/s is 3.6e4-3.6e5 of those, far outside the
// catalogue's [-4, 4] sigma box. A grade scales the IMU effects; GNSS-side effects (latency,
// lever arm) keep their catalogue sigma.
//
//   grade     gyro bias    accel bias   scale / misalign   ARW (deg/sqrt(h)) VRW (m/s/sqrt(h))
//   nav       0.01 deg/h   0.0005 m/s^2 1e-4 / 1e-4 rad    0.002             0.001
//   tactical  1 deg/h      1 mg         3e-4 / 3e-4 rad    0.05              0.02
//   mems      0.1 deg/s    10 mg        1e-3 / 1e-3 rad    0.2               0.05
//
// The [-4, 4] sigma box of a MEMS parameter covers 0.4 deg/s and 40 mg (issue 14's realistic
// 0.2 deg/s, 20 mg lie at 2 sigma). nav's and mems' noise are scenarios/noise.cc's grades (the
// simulator's); tactical's are typical FOG/high-end-MEMS figures. The bias drifts scale with
// the biases (one sigma of drift builds one sigma of bias in an hour, as in the catalogue).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/dataset.h"
#include "identification/ins_problem.h"

namespace insid {

struct SensorGrade {
  std::string name;              ///< "nav" | "tactical" | "mems"
  double gyro_bias_rad_s = 0.0;  ///< one sigma of a gyro bias (rad/s)
  double accel_bias_mps2 = 0.0;  ///< one sigma of an accelerometer bias (m/s^2)
  double scale = 0.0;            ///< one sigma of a scale-factor error (1)
  double misalign_rad = 0.0;     ///< one sigma of a misalignment (rad)
  NoiseLevels noise;             ///< typical white-noise levels of the grade
  /// The grade's sigma (SI) of a catalogue effect; throws on an unknown name (listing them).
  double sigma(std::string_view effect) const;
  /// NAME (the grade's sigma, [-4, 4]), NAME:SIGMA, NAME:SIGMA:LO:HI (EstimatedParameter::parse
  /// with the grade's sigma as the default search unit).
  EstimatedParameter parameter(const std::string& text) const;
};

/// The parameters estimated when none are named (identify, diagnose, campaign configs with an
/// estimation_grade): nav the paper's four at the catalogue's sigmas, as always; tactical and
/// mems the x/y accelerometer and x/y/z gyro biases at the grade's sigmas.
std::vector<EstimatedParameter> default_estimated(const SensorGrade& grade);

/// "nav" | "tactical" | "mems"; throws std::invalid_argument naming the value otherwise.
const SensorGrade& sensor_grade(std::string_view name);
std::vector<std::string> sensor_grade_names();

/// The grade a dataset declares through its meta.json noise block: the angle random walk
/// classifies it (<= 0.01 deg/sqrt(h): nav, <= 0.1: tactical, above: mems). Without a noise
/// block: nullopt (callers fall back to nav, the catalogue, as before grades existed).
std::optional<std::string> declared_grade(const Dataset& dataset);

/// `explicit_grade` when not empty and not "auto", else declared_grade, else "nav".
const SensorGrade& grade_for(const Dataset& dataset, std::string_view explicit_grade = {});

}  // namespace insid
