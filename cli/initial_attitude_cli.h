// The --initial-attitude options shared by navigate, identify and diagnose (issue 14), and the
// record of the mode every result carries.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "core/alignment.h"
#include "core/fitness.h"

namespace insid::cli {

struct InitialAttitudeArgs {
  std::string mode = "gyrocompass";
  double heading_deg = std::numeric_limits<double>::quiet_NaN();  ///< NaN: not given
  std::string heading_source;  ///< "": given with --heading-deg, else course
  double course_min_speed_mps = InitialAttitudeOptions{}.course_min_speed_mps;
  double course_span_s = InitialAttitudeOptions{}.course_span_s;
  double gyrocompass_max_sd_deg = InitialAttitudeOptions{}.gyrocompass_max_heading_sd_deg;
};

/// --initial-attitude, --heading-deg, --heading-source, --course-min-speed, --course-span-s,
/// --gyrocompass-max-sd-deg.
void add_initial_attitude_options(CLI::App* cmd, InitialAttitudeArgs& args);

/// The options (validated: throws std::invalid_argument naming the bad value).
InitialAttitudeOptions initial_attitude_options(const InitialAttitudeArgs& args);

/// The gyro bias allowance of an identification: the largest |box edge| of the estimated
/// horizontal gyro biases (gyro_bias_x/y), else the catalogue default.
double gyro_bias_allowance(const std::vector<std::string>& names,
                           const std::vector<double>& max_abs_si);

/// What the initial attitude of a run was: mode, roll/pitch/yaw at the navigation start for
/// `candidate`, where the heading came from (given, GNSS course with its epochs and the yaw
/// carried back, gyrocompass with its expected sd).
nlohmann::json initial_attitude_json(const NavigationProblem& problem,
                                     const SensorErrors& candidate);

}  // namespace insid::cli
