// The --initial-attitude options shared by navigate, identify and diagnose; the
// record of the mode every result carries is nav/initial_attitude_json.h.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "nav/alignment.h"
#include "nav/fitness.h"
#include "nav/initial_attitude_json.h"  // initial_attitude_json, recorded in every result

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

}  // namespace insid::cli
