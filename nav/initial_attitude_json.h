// What the initial attitude of a run was, recorded in navigate's summary and every
// identify result: the mode, roll/pitch/yaw at the navigation start, where the heading came
// from.
#pragma once

#include <nlohmann/json.hpp>

#include "model/sensor_errors.h"
#include "nav/fitness.h"

namespace insid {

/// Mode, roll/pitch/yaw at the navigation start for `candidate`, where the heading came from
/// (given, GNSS course with its epochs and the yaw carried back, a measured heading, gyrocompass
/// with its expected sd and feasibility check).
nlohmann::json initial_attitude_json(const NavigationProblem& problem,
                                     const SensorErrors& candidate);

}  // namespace insid
