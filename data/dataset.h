// Dataset format `insid-dataset/1` (docs/design.md sec. 5): a directory with imu.csv, gnss.csv,
// optional truth.csv, optional heading.csv (a measured heading) and meta.json. Units are converted
// once here: angles are radians inside.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "base/json_object.h"  // JsonArray
#include "base/output_dir.h"   // write_file_atomic
#include "model/earth.h"
#include "model/rotation.h"
#include "model/sensor_errors.h"

namespace insid {

/// IMU increments over (t_s - dt, t_s], body FRD.
struct ImuSample {
  double t_s = 0.0;
  Eigen::Vector3d dtheta_b_rad = Eigen::Vector3d::Zero();  ///< integrated angular rate (rad)
  Eigen::Vector3d dv_b_mps = Eigen::Vector3d::Zero();      ///< integrated specific force (m/s)
};

/// GNSS antenna solution.
struct GnssSample {
  double t_s = 0.0;
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double h_m = 0.0;
  Eigen::Vector3d v_eb_n_mps = Eigen::Vector3d::Zero();  ///< (vE, vN, vU)
};

/// Reference trajectory of the IMU (truth.csv).
struct TruthSample {
  double t_s = 0.0;
  double lat_rad = 0.0;
  double lon_rad = 0.0;
  double h_m = 0.0;
  Eigen::Vector3d v_eb_n_mps = Eigen::Vector3d::Zero();
  EulerAngles attitude;
};

struct NoiseLevels {
  double arw_deg_rth = 0.0;         ///< angle random walk (deg/sqrt(h))
  double vrw_mps_rth = 0.0;         ///< velocity random walk (m/s/sqrt(h))
  double gnss_vel_sigma_mps = 0.0;  ///< GNSS velocity white noise (m/s)
  double gnss_pos_sigma_m = 0.0;    ///< GNSS position white noise (m)
};

/// A measured heading (heading.csv, optional): the yaw of the body x axis at t_s, clockwise from
/// true north (the frame insid navigates in). A magnetometer heading is stored as true heading:
/// the importer has applied the declination and the tilt compensation (meta.json "heading").
struct HeadingSample {
  double t_s = 0.0;
  double yaw_rad = 0.0;
  std::optional<double> sd_rad;  ///< the sample's sd when the source gives one (column sd_deg)
};

/// Where heading.csv comes from (meta.json "heading").
enum class HeadingSourceKind { kDualAntenna, kMagnetometer };
std::string to_string(HeadingSourceKind kind);  ///< "dual_antenna" | "magnetometer"

struct HeadingMeta {
  HeadingSourceKind source = HeadingSourceKind::kDualAntenna;
  /// Magnetometer only (required there): the magnetic declination (deg, east of true north +)
  /// the importer added to the magnetic heading; recorded, never applied again.
  std::optional<double> declination_deg;
};

/// insid-dataset/1 (simulated data: IMU steps within 1 % of 1/imu_rate_hz, alignment window of
/// round(align_s * imu_rate_hz) rows, initial attitude given) or insid-dataset/2 (measured data,
/// what `insid import` writes: each IMU row's own interval is used, steps may jitter; alignment
/// window = the rows within align_s of the first; the initial attitude may be unknown). One
/// place that lists every difference: README.md, "Dataset formats".
enum class DatasetFormat { kV1 = 1, kV2 = 2 };

struct DatasetMeta {
  DatasetFormat format = DatasetFormat::kV1;
  double imu_rate_hz = 100.0;  ///< /1: the rate; /2: nominal (within 10 % of the median step)
  double gnss_rate_hz = 10.0;
  EarthModel earth;
  double align_s = 600.0;              ///< static alignment window at the start of the data (s)
  TruthSample initial;                 ///< state at the start of the data (initial.t_s)
  bool initial_attitude_known = true;  ///< /2 only may say false (roll/pitch/yaw null)
  std::optional<std::map<std::string, double>> injected;  ///< catalogue name -> SI value
  std::optional<NoiseLevels> noise;
  std::optional<HeadingMeta> heading;  ///< present exactly when heading.csv is
  /// meta.json "motors": when the motors ran (dataset time), for the motor offsets of the error
  /// model (model/sensor_errors.h); empty when the data do not say.
  MotorSchedule motors;
  /// meta.json "motors.source": where the schedule was read (e.g. "RCOU Ch1-Ch4 above 1100 us").
  std::string motors_source;
  /// meta.json "autopilot_estimates": what the recording's own autopilot estimated (e.g. the
  /// ArduPilot EKF's gyro and accelerometer biases), written by the importer for comparison and
  /// never used by insid's computations. Kept verbatim (a JSON object's text, "" when absent)
  /// so that every command that rewrites a dataset carries it along.
  std::string autopilot_estimates_json;
};

struct Dataset {
  DatasetMeta meta;
  std::vector<ImuSample> imu;
  std::vector<GnssSample> gnss;
  std::vector<TruthSample> truth;      ///< empty when truth.csv is absent
  std::vector<HeadingSample> heading;  ///< empty when heading.csv is absent
};

/// Plausibility bounds checked at load (generous: beyond them no real IMU, GNSS receiver or
/// drone produces a value; a value beyond them is a corrupted file, not a flight).
struct PlausibilityBounds {
  static constexpr double kMaxAngularRate_deg_s = 2000.0;  ///< fastest MEMS gyro range
  static constexpr double kMaxSpecificForce_g = 50.0;      ///< beyond shock-rated accelerometers
  static constexpr double kMinHeight_m = -1000.0;          ///< below any land (ellipsoidal)
  static constexpr double kMaxHeight_m = 100000.0;         ///< the edge of space
  static constexpr double kMaxLonAbs_deg = 360.0;          ///< [-180, 180] or [0, 360)
  static constexpr double kMaxSpeed_mps = 1000.0;          ///< per velocity component
  static constexpr double kRateTolerance = 0.10;  ///< declared GNSS rate vs the median step
  static constexpr double kMaxGnssGap_s = 10.0;   ///< longest GNSS outage (or 20 GNSS periods)
  // insid-dataset/2 (jittery IMU stamps):
  static constexpr double kImuRateTolerance2 = 0.10;  ///< declared IMU rate vs the median step
  static constexpr double kMaxImuStep_s = 1.0;        ///< longest IMU step (a longer one: refused)
  static constexpr double kImuGapSteps = 3.0;  ///< a step above this many nominal steps is a gap
  // heading.csv:
  static constexpr double kMaxHeadingAbs_deg = 360.0;  ///< [-180, 180] or [0, 360)
  static constexpr double kMaxHeadingSd_deg = 180.0;   ///< a larger sd says nothing
};

/// A stretch without IMU samples longer than kImuGapSteps nominal steps (insid-dataset/2).
struct ImuGap {
  std::size_t line = 0;  ///< imu.csv line of the row after the gap
  double t_s = 0.0;      ///< its time
  double dt_s = 0.0;     ///< the step
};

/// The IMU gaps of a dataset (reported by import and by navigate; an insid-dataset/1 has none).
std::vector<ImuGap> imu_gaps(const Dataset& dataset);

/// Any malformed dataset input. The message names the file, line and field, and what was
/// expected, e.g. "imu.csv line 12, column dv_x_mps: expected a finite number, got 'nan'".
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A motor schedule from its JSON form, [[on_s, off_s], ...] (meta.json "motors.on_s", a
/// scenario's "motors_on_s"). Throws JsonFieldError naming the element that is not two numbers,
/// or the first bad interval (MotorSchedule::validate).
MotorSchedule read_motor_schedule(const JsonArray& on_s);

/// Load and validate a dataset directory. Throws DatasetError.
Dataset load_dataset(const std::filesystem::path& dir);

struct DatasetWriteOptions {
  /// Write into an existing directory that holds other things than an insid dataset (the
  /// command line's --force): the dataset's files are added (each replaced atomically), the
  /// directory's other files are kept. Without it such a directory is refused.
  bool into_foreign_directory = false;
  /// More files written together with the dataset (plain file name -> contents), e.g.
  /// simulate's answer.json.
  std::map<std::string, std::string> extra_files;
  /// The files the writing command read (an import's sources): the dataset is refused when
  /// writing it would replace or delete one of them, whatever into_foreign_directory says.
  std::vector<std::filesystem::path> inputs;
};

/// Names insid writes into a dataset directory (the format's files, simulate's answer.json,
/// identify's optimum cache, import's provenance record).
const std::vector<std::string>& dataset_directory_entries();

enum class DatasetDestination {
  kReplace,   ///< absent, empty or an insid dataset: (re)placed atomically as a whole
  kAddFiles,  ///< into_foreign_directory: the dataset's files are added, the rest is kept
};

/// What write_dataset would do with `dir`, checked before any work (simulate calls it before
/// simulating). Throws DatasetError when `dir` is refused (the rules below).
DatasetDestination dataset_destination(const std::filesystem::path& dir,
                                       bool into_foreign_directory,
                                       const std::vector<std::filesystem::path>& inputs = {});

/// Write a dataset directory. An absent or empty `dir`, or one holding only an insid dataset
/// (files insid wrote and that are unchanged since: file_owner(), base/output_dir.h; look-alike
/// names are not enough), is replaced atomically: everything goes to a sibling temporary
/// directory that is renamed into place only when complete. A directory holding anything else,
/// or the current directory (or a parent of it), is refused unless
/// `options.into_foreign_directory`; one of `options.inputs` in the way is always refused. Throws
/// DatasetError on refusal or I/O failure, leaving no partial directory behind.
void write_dataset(const std::filesystem::path& dir, const Dataset& dataset,
                   const DatasetWriteOptions& options = {});

/// Where an in-memory dataset's rows and meta fields came from, so that validate_dataset's
/// errors name the user's input rather than the dataset files insid has not written yet (an
/// import validates before it writes). Either function may return "" (unknown: the dataset's
/// own name is used).
struct DatasetSources {
  /// ("imu.csv" | "gnss.csv" | "heading.csv" | "truth.csv", 0-based data row) ->
  /// e.g. "walk.pos line 201".
  std::function<std::string(std::string_view file, std::size_t row)> row;
  /// meta.json field (e.g. "align_s") -> what set it, e.g. "--align-s".
  std::function<std::string(std::string_view field)> field;
};

/// Semantic checks on an in-memory dataset (also run by load_dataset): strictly increasing
/// times, constant IMU rate within tolerance, GNSS covering the flight, finite values.
/// Throws DatasetError naming the file (or `sources`' name for it) and the first offending line.
void validate_dataset(const Dataset& dataset, const DatasetSources& sources = {});
/// validate_dataset's checks of the IMU rows alone (finite, times increasing, increments within
/// PlausibilityBounds; needs meta.imu_rate_hz and meta.format): for an importer, before it
/// looks for a static window in data that may hold a damaged sample.
void validate_imu_values(const Dataset& dataset, const DatasetSources& sources = {});

/// SHA-256 over the files of a dataset directory that determine every result computed from it
/// (meta.json, imu.csv, gnss.csv, and heading.csv when present; truth.csv and other files do not
/// enter): the key of caches kept about the data. Throws DatasetError naming an unreadable file.
std::string dataset_digest(const std::filesystem::path& dir);

}  // namespace insid
