#include "nav/initial_attitude_json.h"

#include "model/rotation.h"
#include "model/units.h"
#include "nav/alignment.h"
#include "nav/mechanization.h"

namespace insid {

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

}  // namespace insid
