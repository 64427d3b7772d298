// Sensor grades: the search unit (sigma) of every catalogue effect and the noise
// levels of a navigation-grade, tactical-grade and MEMS IMU, in physical units. The effect
// catalogue (model/sensor_errors.h) holds the paper's navigation-grade sigmas (0.01 deg/h,
// 0.0005 m/s^2); a MEMS gyro bias of 0.1-1 deg/s is 3.6e4-3.6e5 of those, far outside the
// catalogue's [-4, 4] sigma box. A grade scales the IMU effects; GNSS-side effects (latency,
// lever arm) keep their catalogue sigma.
//
// The figures (one sigma of each error, the noise levels) are the grade table's,
// data/grade_table.h, which the simulator's noise grades and the window study read too.
//
// The [-4, 4] sigma box of a MEMS parameter covers 0.4 deg/s and 40 mg (a realistic MEMS unit's
// 0.2 deg/s, 20 mg lie at 2 sigma). The bias drifts scale with the biases (one sigma of drift
// builds one sigma of bias in an hour, as in the catalogue).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "data/grade_table.h"
#include "identification/ins_problem.h"

namespace insid {

/// An estimation grade: its row of the grade table (data/grade_table.h: name, error sizes,
/// noise) and what identification asks of it.
/// The largest physical size of an effect for a grade (SI) and where the figure comes from.
struct PhysicalLimit {
  double limit_si = 0.0;
  std::string source;
};

struct SensorGrade : GradeFigures {
  /// The grade's sigma (SI) of a catalogue effect; throws on an unknown name (listing them).
  double sigma(std::string_view effect) const;
  /// The largest size of a catalogue effect a unit of this grade has (data/grade_table.h's
  /// physical limits for the IMU effects; GNSS latency 1 s and lever arms 5 m for every grade).
  /// Throws on an unknown name.
  PhysicalLimit physical_limit(std::string_view effect) const;
  /// NAME (the grade's sigma, [-4, 4]), NAME:SIGMA, NAME:SIGMA:LO:HI (EstimatedParameter::parse
  /// with the grade's sigma as the default search unit).
  EstimatedParameter parameter(const std::string& text) const;
};

/// "nav" | "tactical" | "mems"; throws std::invalid_argument naming the value otherwise.
const SensorGrade& sensor_grade(std::string_view name);
std::vector<std::string> sensor_grade_names();

/// The grade a dataset declares through its meta.json noise block: the angle random walk
/// classifies it (<= 0.01 deg/sqrt(h): nav, <= 0.1: tactical, above: mems). Without a noise
/// block: nullopt (callers fall back to nav, the catalogue's sigmas).
std::optional<std::string> declared_grade(const Dataset& dataset);

/// How a grade was settled (`--grade auto` or explicit): the grade, where it came from and the
/// figures it rests on, recorded in every result (`grade_choice`) and printed in one line.
///
/// auto's rule, in order:
/// 1. meta.json's noise block, when present (declared_grade: the angle random walk);
/// 2. else the static alignment window (the IMU rows in the first meta.align_s seconds, at least
///    kMinStaticWindowS): three figures measured there each name a grade, and the coarsest wins
///    (one MEMS sign is enough):
///    - the angle random walk (nav/alignment.h, estimate_arw_rad_rts):
///      <= 0.01 deg/sqrt(h) nav, <= 0.1 tactical, else mems (declared_grade's bounds);
///    - the velocity random walk (estimate_vrw_mps_rts): <= 0.005 m/s/sqrt(h) nav, <= 0.035
///      tactical, else mems (between the grade table's 0.001 / 0.02 / 0.05);
///    - a lower bound on the gyro bias: | |mean rate| - Earth rate | (a static gyro measures
///      Earth rate plus its bias, so |bias| >= that difference), counted only above 3 times its
///      noise (ARW / sqrt(window)): above 20 deg/h (between the table's 1 deg/h and 0.1 deg/s)
///      it votes mems, the only box that holds it (nav's [-4, 4] sigma box ends at 0.04 deg/h,
///      tactical's at 4 deg/h). A smaller bias does not vote: it is what identification is for
///      (a nav unit with a hidden 0.3 deg/h bias stays nav, so diagnose can name the bias).
///    Vibration on the pad counts as noise, so a vehicle with its engine running reads coarser
///    (the safe side: a wider search box, a windowed fitness).
/// 3. else (no static window) nav, the catalogue, said plainly as an assumption.
struct GradeChoice {
  static constexpr double kMinStaticWindowS = 3.0;
  std::string grade;   ///< "nav" | "tactical" | "mems"
  std::string source;  ///< "--grade" | "meta.json noise" | "static window" | "assumed"
  std::string rule;    ///< the rule and the numbers, one line
  // The static window's figures (NaN when not measured).
  double static_window_s = std::nan("");
  double arw_deg_rth = std::nan("");
  double vrw_mps_rth = std::nan("");
  double gyro_bias_min_deg_h = std::nan("");    ///< lower bound on |gyro bias|
  double gyro_bias_noise_deg_h = std::nan("");  ///< its noise, ARW / sqrt(window)
  nlohmann::json to_json() const;
};

/// The grade of `dataset`: `explicit_grade` when not empty and not "auto", else auto's rule.
GradeChoice choose_grade(const Dataset& dataset, std::string_view explicit_grade = {});

/// The grade choose_grade settles on.
const SensorGrade& grade_for(const Dataset& dataset, std::string_view explicit_grade = {});

/// The windowed fitness's default when the user gives no --window-s: 10 s for MEMS data (the
/// accuracy plateau of results/window/README.md, "W = 10-20 s on MEMS data"), 0 (one run, the
/// paper's Eq. 15) otherwise.
double default_window_s(const GradeChoice& choice);

/// The grade and fitness window of an identification or a diagnosis on a dataset: the grade
/// (`grade_arg`: auto from the data by choose_grade, or nav | tactical | mems) and the window
/// (`window_arg`, or the grade's default_window_s when absent). Both are recorded in every
/// result and said in one line.
struct GradeAndWindow {
  GradeChoice grade;
  double window_s = 0.0;
  std::string window_source;  ///< "--window-s" | "default for mems data" | "default: one run"
  /// {"grade_choice": {...}, "window_s_source": ...}
  nlohmann::json to_json() const;
  /// "grade mems (auto: static window ...); fitness window 10 s (default for mems data)"
  std::string line() const;
};
GradeAndWindow settle_grade_and_window(const Dataset& dataset, const std::string& grade_arg,
                                       const std::optional<double>& window_arg);

}  // namespace insid
