// Domain knowledge the report adds to the statistics: which manoeuvre separates two nearly
// collinear effects, and a data-only labelling of flight phases (from the GNSS velocity).
#pragma once

#include <string>
#include <vector>

#include "data/dataset.h"

namespace insid::diagnose {

/// Kind of a catalogue effect, from its sensor and kind in the catalogue: "accel_bias",
/// "gyro_bias", "accel_drift", "gyro_drift", "accel_scale", "gyro_scale", "accel_misalign",
/// "gyro_misalign", "latency", "lever_arm"; "other" for a name not in the catalogue.
std::string effect_kind(const std::string& name);

/// The manoeuvre that would separate two effects that look alike on this flight.
std::string separating_manoeuvre(const std::string& a, const std::string& b);

/// Phase of each GNSS row from the GNSS velocity alone: "slow" (< 3 m/s horizontal), "turn"
/// (|course rate| > 2 deg/s), "speed change" (|d speed/dt| > 0.2 m/s^2), "climb/descent"
/// (|vU| > 0.5 m/s), else "straight". Rates are central differences over +-1 s.
std::vector<std::string> flight_phases(const std::vector<GnssSample>& gnss);

/// Phase names in report order.
const std::vector<std::string>& phase_names();

}  // namespace insid::diagnose
