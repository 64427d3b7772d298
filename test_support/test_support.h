// Test helpers: exact IMU data of a stationary IMU and small in-memory datasets.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "data/dataset.h"
#include "data/static_dataset.h"
#include "model/earth.h"
#include "model/rotation.h"
#include "model/sensor_errors.h"

namespace insid::testing {

/// The paper's Sec. 3.2 injection [-2, 1.5, 2, -1.5] sigma (docs/design.md sec. 2).
inline SensorErrors paper_errors() {
  SensorErrors e;
  e.accel.bias.x() = -2.0 * kSigmaAccelMps2;
  e.accel.bias.y() = 1.5 * kSigmaAccelMps2;
  e.gyro.bias.x() = 2.0 * kSigmaGyroRadS;
  e.gyro.bias.y() = -1.5 * kSigmaGyroRadS;
  return e;
}

/// The same motion sampled with jittered steps (insid-dataset/2): the rows of `fine`, a
/// constant-rate synthesis, summed into consecutive groups of `min_rows`..`max_rows` rows (drawn
/// uniformly from `seed`; equal bounds give a constant rate). Increments are integrals of the
/// body rates, so each group's sum is the exact increment over its span; truth rows (when `fine`
/// has them) follow the groups' last rows, whose indices go to `group_last` when given. Groups are
/// formed while `max_rows` rows remain; `imu_rate_hz` is declared as `nominal_rate_hz`.
inline Dataset jittered_rows(const Dataset& fine, std::size_t min_rows, std::size_t max_rows,
                             std::uint64_t seed, double nominal_rate_hz,
                             std::vector<std::size_t>* group_last = nullptr) {
  Dataset out = fine;
  out.meta.format = DatasetFormat::kV2;
  out.meta.imu_rate_hz = nominal_rate_hz;
  out.imu.clear();
  out.truth.clear();
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> rows(min_rows, max_rows);
  for (std::size_t k = 0; k + max_rows <= fine.imu.size();) {
    ImuSample s;
    for (std::size_t n = rows(rng), j = 0; j < n; ++j, ++k) {
      s.dtheta_b_rad += fine.imu[k].dtheta_b_rad;
      s.dv_b_mps += fine.imu[k].dv_b_mps;
    }
    s.t_s = fine.imu[k - 1].t_s;
    out.imu.push_back(s);
    if (!fine.truth.empty()) out.truth.push_back(fine.truth[k - 1]);
    if (group_last != nullptr) group_last->push_back(k - 1);
  }
  validate_dataset(out);
  return out;
}

/// The stationary IMU of data/static_dataset.h.
using insid::make_static_dataset;

}  // namespace insid::testing
