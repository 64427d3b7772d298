// Test datasets: exact IMU data of a stationary IMU, small in-memory datasets and simulated
// preset flights.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "data/dataset.h"
#include "data/static_dataset.h"
#include "model/sensor_errors.h"

namespace insid::test {

/// The paper's Sec. 3.2 injection [-2, 1.5, 2, -1.5] sigma (docs/design.md sec. 2).
SensorErrors paper_errors();

/// The same motion sampled with jittered steps (insid-dataset/2): the rows of `fine`, a
/// constant-rate synthesis, summed into consecutive groups of `min_rows`..`max_rows` rows (drawn
/// uniformly from `seed`; equal bounds give a constant rate). Increments are integrals of the
/// body rates, so each group's sum is the exact increment over its span; truth rows (when `fine`
/// has them) follow the groups' last rows, whose indices go to `group_last` when given. Groups are
/// formed while `max_rows` rows remain; `imu_rate_hz` is declared as `nominal_rate_hz`.
Dataset jittered_rows(const Dataset& fine, std::size_t min_rows, std::size_t max_rows,
                      std::uint64_t seed, double nominal_rate_hz,
                      std::vector<std::size_t>* group_last = nullptr);

/// The preset scenario `preset` (scenarios/presets/) cut to `flight_s` seconds, with the noise of
/// grade `grade` drawn from `seed`, simulated.
std::shared_ptr<const Dataset> simulate_preset(const std::string& preset, double flight_s,
                                               const std::string& grade, std::uint64_t seed);

/// The stationary IMU of data/static_dataset.h.
using insid::make_static_dataset;

}  // namespace insid::test
