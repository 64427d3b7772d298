// Linear interpolation of the GNSS solution in time: the alignment, the fitness, the EKF and the
// importers read the GNSS values at IMU epochs through it.
#pragma once

#include <vector>

#include "data/dataset.h"

namespace insid {

/// Linear interpolation helper on GNSS rows: value at time t (clamped to the ends). Throws
/// std::invalid_argument when `gnss` is empty.
GnssSample interpolate_gnss(const std::vector<GnssSample>& gnss, double t_s);

}  // namespace insid
