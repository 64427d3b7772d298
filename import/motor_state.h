// When the motors ran, from an autopilot's logged motor outputs (ArduPilot RCOU, PX4
// actuator_outputs): the motor schedule of the dataset (meta.json "motors"), which the motor
// offsets of the error model use (model/sensor_errors.h).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace insid::importers {

/// Motor outputs 1-4 (a quadcopter's motors: ArduCopter's and PX4's default output mapping),
/// PWM microseconds.
inline constexpr int kMotorChannels = 4;
/// A record runs when one output lies more than this above that channel's lowest value in the
/// log (disarmed: 900-1000 us; the armed idle, 1000-1075 us, stays below it: on the shared
/// ArduPilot log the cross-IMU offsets do not move at the idle's 1049 us).
inline constexpr double kMotorRunningUs = 100.0;
inline constexpr double kMotorOffMergeS = 1.0;  ///< runs closer than this are one
inline constexpr double kMotorMinRunS = 0.5;    ///< shorter runs are dropped (damage)
/// Outputs outside this are not PWM widths: a record holding one is left out (damage), and a
/// series without any PWM record gives no schedule.
inline constexpr double kMotorPwmMinUs = 500.0, kMotorPwmMaxUs = 2500.0;

struct MotorRuns {
  std::vector<std::pair<double, double>> on_s;  ///< (on, off), the series' clock (s)
  std::string source;  ///< e.g. "RCOU Ch1-Ch4 more than 100 us above their lowest (...)"
};

/// The runs of a series of motor outputs: `rows` one per logged record, its stamp then outputs
/// 1-4 (PWM us); `kept` the records whose stamps select_increasing_stamps kept, in order;
/// `seconds_per_stamp` the stamp's unit (1e-3: ms, 1e-6: us), giving times on the log's clock.
/// Runs of running records, apart by less than kMotorOffMergeS, make one interval from its first
/// running record to the first record after it that is not (or the last record); runs under
/// kMotorMinRunS are dropped. `series` names the outputs in the source and notes ("RCOU
/// Ch1-Ch4"). nullopt, with a note, when fewer than 2 records are PWM widths.
std::optional<MotorRuns> motor_runs(const std::vector<std::vector<double>>& rows,
                                    const std::vector<std::size_t>& kept, double seconds_per_stamp,
                                    const std::string& series, std::vector<std::string>& notes);

}  // namespace insid::importers
