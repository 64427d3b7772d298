// Assembling an insid-dataset/2 from a user's IMU samples and GNSS solution (`insid import`):
// the common span, quality selection, rates integrated to increments, the static alignment
// window, and a provenance record of every choice made.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/dataset.h"
#include "import/csv_imu.h"
#include "import/gnss_solution.h"

namespace insid::import {

struct AssembleOptions {
  /// RTKLIB quality flags kept (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP); the others are
  /// dropped (and counted in the provenance). Velocities are not re-weighted by their std.
  std::set<int> gnss_quality = {1, 2};
  /// Static alignment window (s); unset: from the first IMU row to 1 s before the first GNSS
  /// epoch whose horizontal speed exceeds static_speed_mps.
  std::optional<double> align_s;
  double static_speed_mps = 0.2;

  /// "" or the first bad field, its value and the allowed range.
  std::string validate() const;
};

struct Assembled {
  Dataset dataset;
  nlohmann::json provenance;  ///< what was read, dropped, derived (no file names: the caller's)
  std::vector<std::string> notes;  ///< for the user: dropped epochs, gaps, the alignment window
};

/// Builds the dataset. IMU rates become increments by the trapezoidal rule over each row's own
/// interval (dtheta_k = (w_{k-1} + w_k) / 2 * (t_k - t_{k-1}); exact for rates linear in time);
/// increments pass through. Times in the dataset count from the whole GPST second at or before
/// the first IMU row used (`time_origin_gpst_unix_s` in the provenance). Only the span both
/// sensors cover is kept. Throws std::runtime_error (no overlap, too few epochs) or DatasetError
/// (the result fails the dataset checks).
Assembled assemble_dataset(const CsvImu& imu, const GnssSolution& gnss,
                           const AssembleOptions& options);

}  // namespace insid::import
