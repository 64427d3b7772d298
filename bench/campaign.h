// Campaigns: scenarios x algorithms x seeds of identification runs, written as JSON files
// (results/README.md documents the schema). Runs are independent and deterministic: a run's
// result depends only on its scenario, algorithm, parameters, budgets and seed, never on the
// thread count or on which runs were done before. Every file is written atomically; a rerun on
// the same directory skips finished runs and redoes the ones cut off. A campaign can be split
// over the ranks of an MPI launch (RunOptions::cluster) or over separately started shards
// (RunOptions::shard) into the same directory; the run files do not depend on the split.
//
// This header is the orchestration (directory and manifest, the run list, shards, MPI units,
// completeness, the summary); the config types, reader, presets and shards are in
// bench/campaign_config.h, the lock-step runner that does the runs in bench/lockstep_runner.h.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/campaign_config.h"
#include "bench/lockstep_runner.h"

namespace insid::campaign {

class Cluster;  // bench/cluster.h

struct RunOptions {
  std::string out_dir;
  int threads = 0;         ///< 0 = OpenMP default
  bool force_new = false;  ///< discard a different campaign's results in out_dir
  /// Write into an out_dir that holds other files than a campaign's (kept; --force).
  bool into_foreign_directory = false;
  /// Where progress goes (scenario preparation, each finished run, ...); empty: nowhere.
  ProgressCallback progress;
  /// No progress at all, even with a callback.
  bool quiet = false;
  /// Stop after this many newly finished runs (for interruption tests); 0 = no limit.
  int max_new_runs = 0;
  /// What a SIGKILL may lose: the runs of the lock-step wave in flight, whose files are written
  /// when the wave ends. Waves are sized to take at most about this many seconds (by the speed
  /// of the scenario's previous wave; a scenario's first wave is the smallest that keeps the
  /// kernel busy, 48 candidates per round per thread); 0 = no time bound (an eighth of the runs
  /// per wave). Not applied to MPI launches, whose units are small waves already.
  double max_wave_s = 10.0;
  /// Called after each lock-step round of this process's runs (performance analysis: insid
  /// bench --round-log); empty: not called. Not applied to MPI launches.
  RoundCallback round_finished;
  /// Score with the scalar reference (NavigationProblem::fitness per candidate) instead of the
  /// batched kernel, for comparisons; results agree within ~1e-12 relative.
  bool scalar_reference = false;
  /// Do only this slice of the runs (any process may then write the summary, once complete).
  Shard shard;
  /// Share the runs with the other ranks of an MPI launch (nullptr: this process alone).
  Cluster* cluster = nullptr;
  /// Extra keys for manifest.json (a sweep stores its own settings there for `insid merge`).
  nlohmann::json manifest_extra = nlohmann::json::object();
  /// Files the command reads besides the scenarios' datasets (its campaign config): a campaign
  /// whose outputs would replace one is refused before any work, --force or not.
  std::vector<std::filesystem::path> inputs;

  /// "" when valid, else why, naming the value: no out_dir, negative threads or max_new_runs, a
  /// negative or non-finite max_wave_s, a shard out of range, --shard with an MPI launch or with
  /// --force-new. run_campaign checks it before any work.
  std::string validate() const;
};

struct CampaignOutcome {
  int total_runs = 0;
  int skipped_runs = 0;  ///< already finished before this invocation
  int new_runs = 0;
  bool complete = false;  ///< every run present (summary written)
  double wall_s = 0.0;
  /// Whether this process writes the campaign-wide files (summary, sweep tables): false on the
  /// MPI ranks other than 0. Counts above are the whole launch's on every rank.
  bool writes_results = true;
  /// New runs done by each MPI rank (empty without MPI).
  std::vector<int> new_runs_per_rank;
  /// When incomplete: which runs are missing, grouped by shard when shards are known.
  std::string missing_report;
};

/// An error every MPI rank has already printed ("insid: error: ..."): the command line exits
/// non-zero without printing it again. (mpiexec ends the whole job at the first non-zero
/// exit, so each rank reports, then all meet, then all exit.)
class ReportedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Run (or resume) a campaign into options.out_dir; writes manifest, runs, optimum files and,
/// once complete, summary.json. Throws std::runtime_error with a clear message on a config
/// mismatch with an existing manifest (unless force_new) or on I/O errors.
CampaignOutcome run_campaign(const CampaignConfig& config, const RunOptions& options);

/// Which run files of `config` are missing from `out_dir` (or damaged), as a readable report:
/// "N of M runs missing" and the files, grouped by shard when `shard_count` > 0. Empty when
/// every run is present.
std::string missing_runs_report(const std::string& out_dir, const CampaignConfig& config,
                                int shard_count);

/// Build summary.json from the run files of a complete campaign directory.
nlohmann::json summarize_campaign(const std::string& out_dir, const CampaignConfig& config);

/// Why a run file's record cannot be used ("" when it can; "missing" when there is no file):
/// it must name this scenario, label and seed under a run schema insid reads (insid-run/1 to
/// the current one), and every number the summary reads (result.fitness, wall_s, evaluations,
/// history, best_per_evaluation, optimum_fitness, the error blocks) must be a finite number.
/// Worded as the typed JSON reader words it (base/json_object.h): "<file>: <path>: <what>",
/// e.g. "runs/x.json: result.fitness: expected a finite number, found a string "0.5"".
/// Campaigns redo such runs.
std::string run_file_problem(const std::filesystem::path& path, const std::string& scenario,
                             const std::string& label, std::uint64_t seed);

/// The run file's record; throws std::runtime_error naming the file and the field that makes it
/// unusable (see run_file_problem).
nlohmann::json read_run_record(const std::filesystem::path& path, const std::string& scenario,
                               const std::string& label, std::uint64_t seed);

}  // namespace insid::campaign
