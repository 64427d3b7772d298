// A campaign's configuration: scenarios x algorithms x seeds and the budgets, read from JSON
// (results/README.md documents the keys) or a preset, written back as the manifest's resolved
// "config", compared with an existing directory's (config_difference), and split into shards.
// Nothing here runs anything: bench/lockstep_runner.h runs, bench/campaign.h orchestrates.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "identification/ins_problem.h"
#include "identification/search_fitness.h"
#include "nav/fitness.h"

namespace insid::campaign {

/// Schemas of a campaign directory's manifest.json and run files.
inline constexpr const char* kManifestSchema = "insid-campaign/1";
// A run record holds the estimate in sigma units as "estimate_in_sigma_units". insid-run/1
// records, still read for resume and merge, call it "estimate_sigma" (a name readers took for an
// sd).
// "parameters" is the uncertainty layout of identify results (objects with name, estimate, sd,
// units, flags; a list of names in insid-run/1 and /2 records, still read), with "correlation"
// and "uncertainty".
inline constexpr const char* kRunSchema = "insid-run/3";
inline constexpr const char* kRunSchemaOld = "insid-run/1";
inline constexpr const char* kRunSchemaPrevious = "insid-run/2";

struct ScenarioSpec {
  std::string name;
  std::string preset;    ///< simulate this preset (or...)
  std::string data_dir;  ///< ...load this dataset directory
  std::optional<double> flight_s;
  std::optional<std::string> grade;
  std::uint64_t data_seed = 1;
  std::map<std::string, double> set;  ///< extra injected effects (SI), on top of the preset's
};

struct AlgorithmSpec {
  std::string label;                         ///< unique within the campaign (directory name)
  std::string name;                          ///< ga | pso | pio | dvpio
  std::map<std::string, double> parameters;  ///< overrides (see `insid identify --param`)
};

struct CampaignConfig {
  std::string name = "custom";
  std::vector<ScenarioSpec> scenarios;
  std::vector<AlgorithmSpec> algorithms;
  std::vector<std::uint64_t> seeds;
  int max_iterations = 40;
  std::int64_t max_evaluations = 0;
  AlignmentMode alignment = AlignmentMode::kPerCandidate;
  /// Initial-attitude mode (nav/alignment.h; `insid identify --initial-attitude`): absent =
  /// gyrocompass (and not written to the resolved config, so campaign directories whose config
  /// lacks the key still resume). Given: the mode, and the key in the resolved config and
  /// every run file. Either way the gyrocompass feasibility check meets the estimated gyro
  /// biases' box, as identify's does (gyro_bias_allowance_rad_s, identification/identify.h).
  std::optional<InitialAttitudeMode> initial_attitude;
  std::optional<double> heading_deg;  ///< level+heading only: the heading (deg); absent: course
  /// level+heading only: "course" | "given" | "measured" (--heading-source); absent: given with
  /// heading_deg, else course (not written).
  std::optional<HeadingSource> heading_source;
  /// Windowed fitness (nav/fitness.h; `--window-s`): 0 = one run (default, not written).
  double window_s = 0.0;
  /// The navigation options of every scenario (alignment, initial attitude, window).
  NavigationOptions navigation_options() const;
  std::vector<std::string> estimate;  ///< --estimate specs; empty = the grade's default set
  /// The grade of the estimation (identification/grade.h; `insid identify --grade`): nav |
  /// tactical | mems, the search unit (sigma) of every `estimate` NAME without SIGMA and the
  /// default set when `estimate` is empty (nav: the paper's four; tactical, mems: also
  /// gyro_bias_z). Not the scenarios' "grade", which is the noise the simulator adds
  /// (scenarios/noise.cc: nav | mems | paper | none). Absent = the catalogue's sigmas and the
  /// paper's four (not written to the resolved config or the run files, so campaign directories
  /// whose config lacks the key still resume). No "auto": a campaign records one
  /// parameter set for all its scenarios.
  std::optional<std::string> estimation_grade;
  int record_positions_seeds = 1;  ///< record particle positions for the first k seeds
  /// Noise replicas of each run's uncertainty (identification/uncertainty.h): the
  /// run file's "parameters" carry sd and flags, "correlation" the matrix. 0 (the default) =
  /// none: the run's parameters are then listed by name only. Cost per run: 2n + 1 + replicas
  /// INS runs of the scalar reference, i.e. about 3x a Table 4 run on a 300 s flight and minutes
  /// per run on the paper's 2.4 h flight, so campaigns ask for it explicitly (results/README.md).
  int uncertainty_replicas = 0;
  /// What steers the optimizers (identification/search_fitness.h; `--fitness`): the fast
  /// second-order model (when its check passes) or the exact kernel. The exact kernel scores every
  /// reported number either way. Always written: a directory whose config lacks the key was
  /// searched on the exact kernel and is not resumed with another fitness.
  SearchFitnessKind search_fitness = SearchFitnessKind::kFast;
  std::vector<double> target_error_sigma = {1.0, 0.3, 0.1};   ///< max |error vs optimum|
  std::vector<double> target_fitness_gap = {1.0, 0.1, 0.01};  ///< (f - f_opt) / f_opt

  /// Resolved config as JSON (the manifest's "config"; also what resume compares).
  nlohmann::json to_json() const;
  /// Throws std::invalid_argument starting with `origin` and naming the bad value: no
  /// scenario, algorithm or seed; a seed listed twice or more than 100000; no budget or a
  /// negative one; a label or scenario name used twice; an unknown algorithm, parameter,
  /// preset, noise grade or estimated effect; a scenario flight that is not positive; a
  /// negative record_positions_seeds. parse_campaign and run_campaign call it before any work.
  void validate(const std::string& origin) const;
};

/// Parse a campaign JSON (documented keys) with insid's one typed reader (base/json_object.h):
/// throws std::invalid_argument "<origin>: <path>: <what>" for an unknown key (naming the valid
/// ones), a missing one, a wrong type (what was expected and what was found) or a bad value.
CampaignConfig parse_campaign(const nlohmann::json& j, const std::string& origin);
/// Reads and parses the campaign config file `path`; every error (unreadable, not strict JSON, a
/// key given twice, a field) is a std::invalid_argument starting with the path.
CampaignConfig read_campaign_file(const std::string& path);
/// Presets: "paper-fig9" (the paper scenario, Table 4 GA/PSO/PIO/DVPIO), "quick" (a short
/// flight for tests and a quick look).
CampaignConfig preset_campaign(const std::string& name);
/// Seeds 1..n.
std::vector<std::uint64_t> seed_range(int n);

/// The estimated parameters of a campaign: identify's (identify_parameters) for its --estimate
/// specs, or the default set, at the estimation_grade's sigmas (nav's, the catalogue's, when
/// absent).
std::vector<EstimatedParameter> estimated_parameters(const CampaignConfig& config);

/// Where an existing directory's resolved config first differs from `new_config` ("" when it
/// is the same campaign; else a path such as "config.algorithms[1].parameters.R"): what
/// resume, shards, MPI launches and merge compare. Parameters an algorithm gained since the
/// old config was written count as the same when the new config has them at their defaults.
std::string config_difference(const nlohmann::json& old_config, const nlohmann::json& new_config);

/// The campaign recorded in a manifest.json (its "config"), checked to round-trip exactly.
CampaignConfig config_from_manifest(const nlohmann::json& manifest, const std::string& origin);

/// Path of one run's file: DIR/runs/<scenario>/<label>/seed_<k>.json. The scenario name and
/// label must be plain names (checked_path_component, base/output_dir.h): no write leaves DIR.
std::string run_file(const std::string& out_dir, const std::string& scenario,
                     const std::string& label, std::uint64_t seed);

/// Path of a scenario's optimum file: DIR/optimum/<scenario>.json (the same check).
std::string optimum_file(const std::string& out_dir, const std::string& scenario);

/// A deterministic slice of a campaign, for batch schedulers without MPI (`--shard i/N`):
/// shard i of N does the runs whose position in the campaign's run list (scenario, algorithm,
/// seed in config order, counted from 0) has remainder i-1 when divided by N.
struct Shard {
  int index = 0;  ///< 1..count
  int count = 0;  ///< 0: not sharded
  bool active() const { return count > 0; }
  bool contains(std::size_t run_position) const {
    return !active() ||
           static_cast<int>(run_position % static_cast<std::size_t>(count)) == index - 1;
  }
  std::string to_string() const { return std::to_string(index) + "/" + std::to_string(count); }
  /// "i/N" with 1 <= i <= N; errors name the value.
  static Shard parse(const std::string& text);
};

}  // namespace insid::campaign
