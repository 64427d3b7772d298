// Is a dataset plausible as what it claims to be? Wrong data imported without a word
// fit, and some fit better than the right data: an IMU clock 18 s off (the GPS-UTC leap
// seconds) gave a smaller model misfit than the right import; specific force in g declared as
// m/s^2 navigated better. These checks compare the data with physics they must obey and say,
// in plain words, what looks wrong: the quantity, the expected and the found value, and the
// likely cause. They run at import and before navigate / identify / diagnose.
//
//   static_gravity     |mean specific force| over the static window against normal gravity
//                      at the start (a MEMS accelerometer's zero-g tolerance is 80 mg, the
//                      MPU-6000 datasheet's: beyond 0.1 g a warning; beyond 0.5 g a refusal);
//   static_attitude    the static mean specific force within 90 deg of -z (forward-right-down
//                      body axes at rest): beyond, the frame is upside down (a mounting off by
//                      180 deg about a horizontal axis); a rotation about the vertical, or one
//                      that keeps the unit upright, cannot be seen from the data;
//   static_earth_rate  the static mean rotation rate against the Earth rate, where the window's
//                      noise lets it be seen (standard error below a tenth of 15 deg/h): far
//                      below it, the gyros are scaled down (deg/s read as rad/s);
//   gyro_turn_rate     in flight, the heading change the gyros measure about the specific
//                      force's direction against the GNSS course change (slope 1 expected):
//                      57.3 or 1/57.3 is a deg/s - rad/s mix-up;
//   gnss_velocity      the GNSS velocity against the rate of change of the GNSS positions over
//                      >= 2 s (a 2 x 2 horizontal fit and the vertical slope, identity
//                      expected): swapped, negated or scaled axes (km/h, knots);
//   imu_gnss_clock     the IMU's |f|^2 - g^2 against the GNSS's |a|^2 + 2 g a_up (both the
//                      same function of the acceleration, whatever the attitude) shifted by
//                      -30 .. 30 s: a clearly better match away from 0 is a clock offset (18 s:
//                      GPS-UTC leap seconds).
// A check that the data cannot support (no static window, no turns, too little motion) says so
// in `not_checked`, never a warning.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"

namespace insid {

struct PlausibilityFinding {
  enum class Level { kWarning, kRefusal };
  Level level = Level::kWarning;
  std::string check;         ///< "static_gravity", "gnss_velocity", ...
  std::string quantity;      ///< what was measured, in words
  std::string expected;      ///< the value physics wants, with unit
  std::string found;         ///< the value in the data, with unit
  std::string likely_cause;  ///< the most likely mistake, in words

  /// "static specific force magnitude: expected 9.80 m/s^2 (...), found 1.00 m/s^2: likely ..."
  std::string text() const;
  nlohmann::json to_json() const;
};

struct PlausibilityReport {
  std::vector<PlausibilityFinding> findings;
  std::vector<std::string> not_checked;  ///< "gyro_turn_rate: fewer than 90 deg of turns", ...
  bool refused() const;
  /// {"findings": [...], "not_checked": [...]}
  nlohmann::json to_json() const;
};

/// Runs every check on `dataset` (cheap: one pass over the IMU rows, a few over the GNSS).
PlausibilityReport check_plausibility(const Dataset& dataset);

}  // namespace insid
