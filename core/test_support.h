// Test helpers: exact IMU data of a stationary IMU and small in-memory datasets.
#pragma once

#include <cmath>

#include "core/dataset.h"
#include "core/earth.h"
#include "core/rotation.h"
#include "core/sensor_errors.h"
#include "core/static_dataset.h"

namespace insid::testing {

/// The paper's Sec. 3.2 injection [-2, 1.5, 2, -1.5] sigma (DESIGN.md sec. 2).
inline SensorErrors paper_errors() {
  SensorErrors e;
  e.accel.bias.x() = -2.0 * kSigmaAccelMps2;
  e.accel.bias.y() = 1.5 * kSigmaAccelMps2;
  e.gyro.bias.x() = 2.0 * kSigmaGyroRadS;
  e.gyro.bias.y() = -1.5 * kSigmaGyroRadS;
  return e;
}

/// The stationary IMU of core/static_dataset.h.
using insid::make_static_dataset;

}  // namespace insid::testing
