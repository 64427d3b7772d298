// Assembling an insid-dataset/2 from a user's IMU samples and GNSS solution (`insid import`):
// the common span, quality selection, rates integrated to increments, the static alignment
// window, and a provenance record of every choice made.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "import/csv_imu.h"
#include "import/gnss_solution.h"

namespace insid::importers {

/// The default lowest IMU rate (Hz) for strapdown integration. A multicopter's rigid-body motion
/// (attitude manoeuvres, the attitude controller's corrections) reaches ~5 Hz. Sampled at f_s,
/// everything above the Nyquist frequency f_s / 2 folds back onto lower frequencies (aliasing),
/// and below it the trapezoid integrates a rate oscillating at f with the gain
/// (w h / 2) / tan(w h / 2), w = 2 pi f, h = 1 / f_s (exact for a line, low for curvature):
///   f_s = 20 Hz: a 5 Hz motion sits at half the Nyquist frequency, integrated at 0.79 of its
///                amplitude (a 2 Hz manoeuvre at 0.97);
///   f_s = 50 Hz (ArduPilot's logged IMU): 5 Hz at 0.97 (imported, with an aliasing note);
///   f_s =  8.6 Hz (px4-ulog-real: sensor_combined decimated by the logger): the Nyquist
///                frequency, 4.3 Hz, lies inside the manoeuvre band, so the logged samples
///                cannot describe the motion between them at all.
/// 20 Hz = 4 x 5 Hz: the Nyquist frequency twice the top of the band. A decimated log of
/// per-sample means (sensor_combined) is no better than point samples at its logged rate: each
/// logged mean covers its own ~4 ms sample, not the ~100 ms to the next logged row.
inline constexpr double kDefaultMinImuRateHz = 20.0;

struct AssembleOptions {
  /// RTKLIB quality flags kept (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP); the others are
  /// dropped (and counted in the provenance). Velocities are not re-weighted by their std.
  std::set<int> gnss_quality = {1, 2};
  /// Static alignment window (s); unset: detected (static_window_end below), from the first IMU
  /// row to the earlier of
  ///   * 1 s before the first GNSS epoch whose horizontal speed exceeds static_speed_mps, and
  ///   * the start of the 0.5 s IMU block before the first block that moves: its mean angular
  ///     rate departs from the mean over the blocks before it by more than static_rate_dps on
  ///     an axis (a turn on the spot: the GNSS does not see it), or its specific-force magnitude
  ///     scatters (sample sd) by more than static_accel_sd_mps2 (steps, handling).
  /// The gyro bias and Earth rate cancel in the rate's departure; the thresholds are far above
  /// the white noise of a 0.5 s block mean of a MEMS gyro (0.005 deg/s for 0.2 deg/sqrt(h)).
  std::optional<double> align_s;
  double static_speed_mps = 0.2;
  /// Block-mean angular rate departure (deg/s) that ends the static window: 2 deg/s turns the
  /// unit by 1 deg in a block.
  double static_rate_dps = 2.0;
  /// Sample sd of |specific force| within a block (m/s^2) that ends the static window (0.1 m/s^2
  /// ~ 10 mg: a hand-held phone scatters 0.003-0.07, walking steps 0.2-0.9). A platform that
  /// vibrates while still (motors armed) may need a larger value.
  double static_accel_sd_mps2 = 0.1;
  /// Magnetic declination (deg, east of true north +) added to a magnetometer heading to make
  /// it a true heading: required when the heading source is a magnetometer (no world magnetic
  /// model here), refused otherwise; recorded in meta.json "heading".
  std::optional<double> declination_deg;
  /// The lowest IMU rate (Hz: 1 / the median step of the rows used) insid integrates
  /// (`--min-imu-rate-hz`): a slower log is refused before anything is written. The default,
  /// kDefaultMinImuRateHz, is set for multicopters; a platform whose motion is slower (a ship, a
  /// car on a smooth road) may lower it, to four times its highest manoeuvre frequency.
  double min_imu_rate_hz = kDefaultMinImuRateHz;

  /// "" or the first bad field, its value and the allowed range.
  std::string validate() const;
};

/// The end (s, on the dataset's t_s) of the motionless start of `imu` up to `t_limit_s`, by the
/// IMU criteria of AssembleOptions (0.5 s blocks from the first row): the start of the block
/// before the first moving block, or t_limit_s when none moves before it. `why` says which
/// criterion ended it (empty when none did).
struct ImuStaticEnd {
  double t_end_s = 0.0;
  std::string why;
};
ImuStaticEnd static_window_end(const std::vector<ImuSample>& imu, double t_limit_s,
                               const AssembleOptions& options);

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
/// With a heading (`heading`, else imu.heading when set): heading.csv holds the samples inside
/// the dataset's span, times on the dataset's clock. A dual-antenna heading passes through
/// (wrapped to (-180, 180] deg) with its sd; a magnetometer's is made a true heading with the
/// declination and levelled with the static window's mean specific force
/// (magnetometer_true_heading_rad), so only the samples inside the static window are written
/// (outside it the tilt is not known to the importer).
Assembled assemble_dataset(const CsvImu& imu, const GnssSolution& gnss,
                           const AssembleOptions& options, const HeadingInput* heading = nullptr);

}  // namespace insid::importers
