#include "cli/initial_attitude_cli.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cli/cli_util.h"
#include "core/rotation.h"

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
    throw std::invalid_argument("--initial-attitude: " + why);
  return o;
}

double gyro_bias_allowance(const std::vector<std::string>& names,
                           const std::vector<double>& max_abs_si) {
  double allowance = -1.0;
  for (std::size_t k = 0; k < names.size() && k < max_abs_si.size(); ++k)
    if (names[k] == "gyro_bias_x" || names[k] == "gyro_bias_y")
      allowance = std::max(allowance, max_abs_si[k]);
  return allowance >= 0.0 ? allowance : InitialAttitudeOptions{}.gyro_bias_allowance_rad_s;
}

nlohmann::json initial_attitude_json(const NavigationProblem& problem,
                                     const SensorErrors& candidate) {
  const InitialAttitude& source = problem.initial_attitude_source();
  const InitialAttitudeOptions& o = source.options();
  nlohmann::json j;
  j["mode"] = to_string(o.mode);
  j["description"] = o.describe();
  const EulerAngles att = euler_from_C_b_n(problem.initial_attitude(candidate));
  j["at_t_s"] = problem.nav_start_t_s();
  j["attitude_deg"] = {{"roll", att.roll_rad * kRadToDeg},
                       {"pitch", att.pitch_rad * kRadToDeg},
                       {"yaw", wrap_two_pi(att.yaw_rad) * kRadToDeg}};
  switch (o.mode) {
    case InitialAttitudeMode::kGyrocompass:
      j["heading_source"] = "gyrocompass";
      if (source.feasibility()) {
        j["gyrocompass_heading_sd_deg"] = source.feasibility()->heading_sd_rad * kRadToDeg;
        j["gyrocompass_max_heading_sd_deg"] = o.gyrocompass_max_heading_sd_deg;
        j["gyrocompass_check"] = source.feasibility()->describe();
      }
      break;
    case InitialAttitudeMode::kLevelHeading:
      if (const auto& m = source.measured_heading()) {
        j["heading_source"] = "measured";
        nlohmann::json h = {
            {"kind", to_string(m->kind)},
            {"samples", m->count},
            {"heading_csv_first_line", m->first_line},
            {"t_first_s", m->t_first_s},
            {"t_last_s", m->t_last_s},
            {"span_s", m->t_last_s - m->t_first_s},
            {"where", m->carried ? "after the navigation start, carried back "
                                   "to it with the compensated gyros"
                                 : "static window"},
            {"mean_deg", wrap_two_pi(m->mean_rad) * kRadToDeg},
            {"scatter_deg", m->scatter_rad * kRadToDeg},
            {"sample_sd_deg", m->sample_sd_rad ? nlohmann::json(*m->sample_sd_rad * kRadToDeg)
                                               : nlohmann::json(nullptr)},
            {"heading_sd_deg", m->sd_rad * kRadToDeg},
            {"sd_assumption",
             "max(sample sd, scatter) / sqrt(samples): independent samples; a "
             "slowly varying error (multipath, a magnetometer's hard iron) is "
             "not averaged out and not in it"}};
        if (m->declination_deg) h["declination_deg"] = *m->declination_deg;
        if (m->carried) {
          const ImuCompensator compensator(candidate);
          nlohmann::json samples = nlohmann::json::array();
          for (const CourseFix& f : source.course_fixes())
            samples.push_back(
                {{"t_s", f.t_s},
                 {"heading_csv_line", f.gnss_index + 2},
                 {"heading_deg", wrap_two_pi(f.course_rad) * kRadToDeg},
                 {"yaw_change_since_start_deg", source.yaw_change_to(f, compensator) * kRadToDeg}});
          h["carried_samples"] = samples;
        }
        j["measured_heading"] = h;
      } else if (o.heading_deg) {
        j["heading_source"] = "given";
        j["heading_given_deg"] = *o.heading_deg;
      } else {
        j["heading_source"] = "gnss_course";
        const auto& fixes = source.course_fixes();
        const ImuCompensator compensator(candidate);
        nlohmann::json epochs = nlohmann::json::array();
        for (const CourseFix& f : fixes)
          epochs.push_back(
              {{"t_s", f.t_s},
               {"gnss_csv_line", f.gnss_index + 2},
               {"speed_mps", f.speed_mps},
               {"course_deg", wrap_two_pi(f.course_rad) * kRadToDeg},
               {"yaw_change_since_start_deg", source.yaw_change_to(f, compensator) * kRadToDeg}});
        j["course_min_speed_mps"] = o.course_min_speed_mps;
        j["course_span_s"] = o.course_span_s;
        j["course_t_s"] = fixes.empty() ? nlohmann::json() : nlohmann::json(fixes.front().t_s);
        j["course_epochs"] = epochs;
        j["assumption"] =
            "body x axis along the horizontal velocity at the course epochs (cars, walkers; "
            "not a vehicle moving sideways), course carried back to the start with the "
            "compensated gyros";
      }
      break;
    case InitialAttitudeMode::kGiven:
      j["heading_source"] = "meta.json initial";
      break;
    case InitialAttitudeMode::kTruth:
      j["heading_source"] = "truth";
      break;
  }
  return j;
}

}  // namespace insid::cli
