// From an ArduPilot DataFlash log to the IMU samples and GNSS solution that assemble_dataset
// takes (`insid import ardupilot`). IMU records carry the boot clock (TimeMS, ms since boot);
// GPS records carry GPS week and time of week (Week, TimeMS) and the boot clock when logged (T).
// A linear fit of GPST against T over the fixes puts the IMU on GPST, the scale of the other
// importers (gnss_solution.h).
#pragma once

#include <optional>
#include <utility>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "import/csv_imu.h"
#include "import/dataflash.h"
#include "import/gnss_solution.h"

namespace insid::import {

struct ArduPilotImportOptions {
  std::string imu = "IMU";  ///< the IMU message: IMU, IMU2 or IMU3 (one physical IMU each)
  int min_status = 3;       ///< GPS Status kept: 3 = 3D fix and above
  std::optional<double> t_start_s, t_end_s;  ///< boot seconds: records outside are cut
  std::string validate() const;
};

/// The linear relation GPST = gpst_at_zero + slope * boot over the fixes.
struct BootClockFit {
  long double gpst_at_boot_zero_s = 0.0L;
  double slope = 1.0;
  double rms_s = 0.0, max_abs_s = 0.0;  ///< residuals of the fixes kept in the fit
  std::size_t fixes = 0, excluded = 0;  ///< excluded: residual beyond kBootFitOutlierS at first
};
inline constexpr double kBootFitOutlierS = 0.1;
inline constexpr double kImuGapMedianSteps = 3.0;

/// Sign of VZ from a fit of the altitude's rate (central differences of Alt over the fixes)
/// on VZ: d(Alt)/dt = s * VZ.
struct VzSign {
  double s = 0.0, correlation = 0.0;
  std::size_t pairs = 0;
  bool conclusive = false;  ///< |correlation| >= 0.5 over >= 20 pairs
  bool down_positive = true;
};

struct ArduPilotSeries {
  CsvImu imu;  ///< point samples of rate (rad/s) and specific force (m/s^2), body FRD
  GnssSolution gnss;
  BootClockFit clock;
  VzSign vz;
  /// Steps between kept IMU records longer than kImuGapMedianSteps median steps: (boot s of the
  /// record before the gap, gap s). Longer than PlausibilityBounds::kMaxImuStep_s, the dataset
  /// refuses them: the caller cuts them out (--t-start / --t-end).
  std::vector<std::pair<double, double>> imu_gaps_boot_s;
  nlohmann::json provenance;
  std::vector<std::string> notes;
};

/// Reads options.imu and GPS. IMU: TimeMS, GyrX/Y/Z, AccX/Y/Z (sampled values, not increments:
/// assemble_dataset integrates them as point samples by the trapezoid); records whose TimeMS does
/// not increase are dropped and counted. GPS: Status >= min_status; horizontal velocity
/// Spd along GCrs, vertical from VZ with the sign the fit gives (down positive, ArduPilot's
/// convention, when the fit is not conclusive); height Alt (MSL). Throws std::runtime_error
/// naming the file and what is missing.
ArduPilotSeries extract_ardupilot(const DataFlashFile& log, const std::string& where,
                                  const ArduPilotImportOptions& options);

}  // namespace insid::import
