// Parameter sweeps (PIO/DVPIO R, d, premature threshold, ...): every setting over the same
// seeds, run as a campaign (same resume and atomicity rules), then per-setting statistics.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/campaign.h"

namespace insid::campaign {

/// One swept parameter: its values (user units; keys ending in _sigma are sigma units).
struct SweepAxis {
  std::string key;
  std::vector<double> values;
  double lo = 0.0, hi = 0.0;  ///< range (for --random)
  /// "R=0.01:0.3:6" (6 values, linear), "R=0.01,0.05,0.2" (a list), "R=0.05" (one value).
  static SweepAxis parse(const std::string& text);
};

struct SweepConfig {
  std::string algorithm = "dvpio";
  std::vector<SweepAxis> axes;
  int random_settings =
      0;  ///< > 0: that many random settings in the axes' ranges instead of the grid
  std::uint64_t random_seed = 1;
  ScenarioSpec scenario;
  std::vector<std::uint64_t> seeds = seed_range(11);
  int max_iterations = 40;
  std::int64_t max_evaluations = 0;
  AlignmentMode alignment = AlignmentMode::kPerCandidate;
  /// The initial-attitude campaign keys (campaign_config.h): absent = gyrocompass.
  std::optional<InitialAttitudeMode> initial_attitude;
  std::optional<double> heading_deg;
  double window_s = 0.0;
  /// The campaign key estimation_grade (nav | tactical | mems; absent = the catalogue's sigmas).
  /// Not scenario.grade, the simulated noise.
  std::optional<std::string> estimation_grade;

  /// "" when valid, else what is wrong, naming the bad value: no axis, an axis key given twice
  /// or with no values, a non-finite value or LO > HI, negative random_settings, no seed,
  /// negative budgets. sweep_settings and run_sweep refuse an invalid sweep before any work
  /// (std::invalid_argument with this text).
  std::string validate() const;
};

/// The settings (user units, keys as given), grid order or random draws.
std::vector<std::map<std::string, double>> sweep_settings(const SweepConfig& sweep);

/// The campaign that runs the sweep (one algorithm label "s<index>" per setting).
CampaignConfig sweep_campaign(const SweepConfig& sweep);

/// Run (or resume) a sweep into options.out_dir; when complete, write sweep.json and
/// sweep.csv there. Returns the campaign outcome. The sweep's own settings are stored in the
/// manifest ("sweep") so that `insid merge` can write the tables of a sharded sweep.
CampaignOutcome run_sweep(const SweepConfig& sweep, const RunOptions& options);

/// sweep.json and sweep.csv of a complete sweep directory.
void write_sweep_results(const SweepConfig& sweep, const CampaignConfig& campaign,
                         const std::string& out_dir);

/// The manifest's "sweep" entry and back (what write_sweep_results needs: algorithm, axes,
/// random settings, scenario name, seeds).
nlohmann::json sweep_to_manifest(const SweepConfig& sweep);
SweepConfig sweep_from_manifest(const nlohmann::json& j, const std::string& origin);

/// `insid merge DIR`: once every run of the campaign (or sweep) in DIR is present, whoever
/// wrote it (shards, MPI ranks, single runs), write summary.json (and a sweep's sweep.json,
/// sweep.csv). Throws std::runtime_error listing the missing runs, by shard when the
/// manifest records shards, otherwise. Returns the number of runs.
int merge_results(const std::string& dir);

}  // namespace insid::campaign
