// Scenario configuration (JSON files and named presets) and the whole simulation:
// config -> trajectory -> exact IMU increments and truth -> GNSS -> errors and noise -> Dataset.
// The JSON keys are documented in scenarios/README.md; unknown keys are rejected.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "model/earth.h"
#include "model/sensor_errors.h"
#include "scenarios/noise.h"
#include "scenarios/trajectory.h"

namespace insid::scenarios {

struct ScenarioConfig {
  std::string name = "custom";
  std::string description;
  std::string origin = "scenario";  ///< where it came from (file or preset), for messages
  double imu_rate_hz = 100.0;
  double gnss_rate_hz = 10.0;
  EarthModel earth;                   ///< default WGS-84
  std::string earth_model = "wgs84";  ///< "wgs84" | "paper" | "custom" (as given)
  InitialPose initial;                ///< radians
  double align_s = 600.0;             ///< static alignment at the start (s)
  std::optional<double> flight_s;     ///< flight after the alignment (s); default: the segments
  nlohmann::json segments = nlohmann::json::array();  ///< played once after the alignment
  nlohmann::json repeat = nlohmann::json::array();    ///< then cycled until flight_s
  int substeps = 4;                                   ///< RK4 sub-steps per IMU interval
  NoiseSpec noise;                                    ///< default: grade "none"
  SensorErrors injected;                              ///< SI
  /// "motors_on_s": when the motors run (data time, s), for the motor offsets; written to the
  /// dataset's meta.json "motors" like an autopilot's log would give it. Empty: not modelled.
  MotorSchedule motors;
  std::uint64_t seed = 1;
};

/// Parse a scenario from JSON with insid's one typed reader (base/json_object.h). `origin`
/// prefixes every message (e.g. the file name). Throws std::invalid_argument naming the field's
/// path, e.g. "my.json: segments[2].bank: unknown key (valid keys: type, turn_deg, direction,
/// bank_deg, rate_deg_s, ramp_s, comment)".
ScenarioConfig parse_scenario(const nlohmann::json& j, const std::string& origin);
/// Read and parse a scenario file (every error a std::invalid_argument starting with the path:
/// unreadable, not strict JSON, a key given twice, a field).
ScenarioConfig load_scenario_file(const std::filesystem::path& path);
/// Named presets: paper, racetrack, rich, straight, multicopter.
std::vector<std::string> preset_names();
/// Preset by name; throws std::invalid_argument listing the names when unknown.
ScenarioConfig preset_scenario(std::string_view name);
/// The effective configuration as JSON (parse_scenario reads it back to the same config).
nlohmann::json scenario_to_json(const ScenarioConfig& cfg);

/// What a caller changes in a scenario before simulating it: the command line's --seed,
/// --grade, --flight-s, --clean, --set, a campaign's scenario spec, diagnose's hidden cases.
struct ScenarioOverrides {
  std::optional<std::uint64_t> seed;
  std::optional<std::string> grade;   ///< noise_grade(grade) replaces the noise block
  std::optional<double> flight_s;     ///< flight after the alignment (s)
  bool clean = false;                 ///< drop the scenario's own injected errors first
  std::map<std::string, double> set;  ///< catalogue effects (SI) injected on top
};
/// `cfg` with `overrides` applied (unknown grades and effect names throw, naming them).
ScenarioConfig with_overrides(ScenarioConfig cfg, const ScenarioOverrides& overrides);

/// What a configuration expands to.
struct ScenarioPlan {
  Trajectory trajectory;
  double flight_s = 0.0;          ///< after the alignment
  std::size_t num_imu_steps = 0;  ///< rows of imu.csv
  std::size_t num_gnss = 0;       ///< rows of gnss.csv
};
/// Validate and expand a configuration (all semantic checks: durations, bank angles, rates).
ScenarioPlan plan_scenario(const ScenarioConfig& cfg);

/// Run the whole simulation. `record_truth_in_meta` = false leaves `injected` and `noise` out of
/// meta.json (data that look measured; the answer goes to answer_json()).
/// `threads`: OpenMP threads of the IMU synthesis (the same data for any count).
Dataset simulate(const ScenarioConfig& cfg, bool record_truth_in_meta = true, int threads = 1);
/// Same, reusing a plan.
Dataset simulate(const ScenarioConfig& cfg, const ScenarioPlan& plan,
                 bool record_truth_in_meta = true, int threads = 1);

/// The one "preset -> overrides -> simulate" path: simulate(with_overrides(
/// preset_scenario(preset), overrides), record_truth_in_meta).
Dataset simulate_preset(std::string_view preset, const ScenarioOverrides& overrides,
                        bool record_truth_in_meta = true, int threads = 1);

/// A measured heading written with a simulation (insid simulate --heading; heading.csv).
struct HeadingStreamSpec {
  HeadingSourceKind source = HeadingSourceKind::kDualAntenna;
  double rate_hz = 5.0;  ///< samples per second, from the first IMU row
  /// Dual antenna: white noise on the truth yaw (deg), also written as each sample's sd.
  double sd_deg = 0.5;
  /// Magnetometer: the Earth field at the site, ENU: B (cos I sin D, cos I cos D, -sin I) with
  /// declination D (east +) and inclination I (down +); white noise per body axis as a fraction
  /// of |B|. The stream is what `insid import` writes from such a magnetometer: levelled with
  /// the static window's mean specific force and D added (declination_deg is recorded), so only
  /// the samples inside the static window are written.
  double declination_deg = 0.0;
  double inclination_deg = 60.0;
  double mag_noise_fraction = 0.005;
  std::uint64_t seed = 1;
  /// "" when valid, else the reason naming the bad value.
  std::string validate() const;
};

/// Adds heading.csv samples (and meta.json "heading") to a simulated dataset from its truth.csv
/// attitude. Throws std::invalid_argument (invalid spec, no truth).
void add_heading_stream(Dataset& dataset, const HeadingStreamSpec& spec);

/// The ground truth of a simulation (written to answer.json with --no-injected).
nlohmann::json answer_json(const ScenarioConfig& cfg);

}  // namespace insid::scenarios
