#include "cli/initial_attitude_cli.h"

#include <cmath>
#include <stdexcept>

#include "cli/cli_util.h"
#include "cli/commands.h"

namespace insid::cli {

void add_initial_attitude_options(CLI::App* cmd, InitialAttitudeArgs& args) {
  cmd->add_option("--initial-attitude", args.mode,
                  "gyrocompass (static levelling + gyrocompassing; 'align' is the old name) | "
                  "level+heading (levelling + --heading-deg or the GNSS course) | given "
                  "(meta.json initial roll/pitch/yaw) | truth (truth.csv, simulated data); "
                  "README.md, 'Initial attitude'")
      ->capture_default_str();
  cmd->add_option("--heading-deg", args.heading_deg,
                  "level+heading: heading at the navigation start (deg, clockwise from north); "
                  "default: the GNSS course carried back to the start")
      ->check(number_in(-360.0, 360.0));
  cmd->add_option("--heading-source", args.heading_source,
                  "level+heading: course (the GNSS course) | given (--heading-deg) | measured "
                  "(the dataset's heading.csv: dual antenna or magnetometer); default: given "
                  "with --heading-deg, else course");
  cmd->add_option("--course-min-speed", args.course_min_speed_mps,
                  "level+heading: GNSS horizontal speed (m/s) from which the course is used")
      ->capture_default_str()
      ->check(number_in(1e-3, 1000.0));
  cmd->add_option("--course-span-s", args.course_span_s,
                  "level+heading: mean course over the fast GNSS epochs within this span (s) after "
                  "the first one")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0));
  cmd->add_option("--gyrocompass-max-sd-deg", args.gyrocompass_max_sd_deg,
                  "gyrocompass: refused when the expected heading sd exceeds this (deg)")
      ->capture_default_str()
      ->check(number_in(1e-6, 180.0));
}

InitialAttitudeOptions initial_attitude_options(const InitialAttitudeArgs& args) {
  InitialAttitudeOptions o;
  o.mode = initial_attitude_mode_from_string(args.mode);
  if (!std::isnan(args.heading_deg)) o.heading_deg = args.heading_deg;
  if (!args.heading_source.empty())
    o.heading_source = heading_source_from_string(args.heading_source);
  o.course_min_speed_mps = args.course_min_speed_mps;
  o.course_span_s = args.course_span_s;
  o.gyrocompass_max_heading_sd_deg = args.gyrocompass_max_sd_deg;
  if (const std::string why = o.validate(); !why.empty())
    throw UsageError("--initial-attitude: " + why);  // conflicting options: exit 2
  return o;
}

}  // namespace insid::cli
