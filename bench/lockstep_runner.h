// The campaign's lock-step runner: runs given positions of a campaign's run list in waves of
// consecutive runs of one scenario that advance generation by generation and share their
// fitness batches (one evaluate_batch call per generation for the whole wave), prepares each
// scenario on first use (dataset, INS problem, the data's own optimum, found or read from
// DIR/optimum/) and writes each run's file as soon as the run is done. What it has to say goes to a
// progress callback; it prints nothing itself. The orchestration (directory, manifest, run list,
// shards, MPI units, summary) is bench/campaign.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bench/campaign_config.h"

namespace insid::campaign {

/// What a campaign has to report while it runs; the caller decides how to show it (the command
/// line prints it to stderr: cli/cli_util.h campaign_progress_printer).
struct ProgressEvent {
  enum class Kind {
    kRemovedTemporaries,  ///< `count` temporary files of an interrupted run removed from `path`
    kRedoingDamagedRun,   ///< `detail`: why the run file cannot be used
    kPreparingScenario,   ///< `scenario`: simulating or loading its data
    kFindingOptimum,      ///< `scenario`: finding the data's own optimum
    kWaitingForOptimum,   ///< `path`: the optimum file another MPI rank is writing
    kRunFinished,         ///< `scenario`, `algorithm`, `seed` written; the counts and times
    kRunsEnded,           ///< the last new run of this invocation is written
  };
  Kind kind = Kind::kRunFinished;
  std::string scenario{};
  std::string algorithm{};  ///< the algorithm's label
  std::uint64_t seed = 0;
  std::string path{};
  std::string detail{};
  int count = 0;
  int runs_present = 0;    ///< kRunFinished: runs done before this invocation + new_runs
  int runs_total = 0;      ///< kRunFinished: runs in the campaign
  int new_runs = 0;        ///< kRunFinished: runs this process has finished so far
  double elapsed_s = 0.0;  ///< kRunFinished: since the runner started
  double eta_s = 0.0;      ///< kRunFinished: estimated time left for this process's runs
  bool mpi_rank = false;   ///< kRunFinished: counts are this MPI rank's alone
};
using ProgressCallback = std::function<void(const ProgressEvent&)>;

/// One run of the campaign's run list.
struct RunSpec {
  std::size_t scenario, algorithm;  ///< indices into the config's lists
  std::uint64_t seed;
  std::string path;  ///< its run file
};

/// What a process does about a scenario's optimum file when it is absent.
enum class OptimumSource {
  kCompute,  ///< find it and write it (single process, shards, the first MPI rank of a scenario)
  kWait,     ///< another MPI rank is finding it: wait for its file when a run needs it
};

/// One lock-step round, as timed by run_together (for performance analysis: insid bench
/// --round-log, scripts/perf_rounds.py).
struct RoundRecord {
  std::size_t wave = 0;        ///< the wave's number in this process, from 0
  std::size_t wave_runs = 0;   ///< runs in the wave
  std::size_t candidates = 0;  ///< candidates asked for in this round
  std::size_t scored = 0;      ///< of them scored: the others repeat one already scored
  double scoring_s = 0.0;      ///< wall time of their scoring [s]
  double round_s = 0.0;        ///< wall time of the whole round (asks, tells, run files) [s]
};
using RoundCallback = std::function<void(const RoundRecord&)>;

struct RunnerSettings {
  std::string out_dir;
  int threads = 1;                ///< OpenMP threads of the fitness evaluations
  bool scalar_reference = false;  ///< score with the scalar reference evaluator
  bool mpi_rank = false;          ///< one rank of an MPI launch (progress counts are its own)
  ProgressCallback progress;      ///< may be empty (nothing reported)
  /// Wall-time bound of a wave (what a kill can lose): after a scenario's first wave, whose
  /// speed sizes the next, waves take about this long at most, but never fewer candidates per
  /// round than wave_target(threads, 0); 0 = no bound (waves of wave_target's size).
  double max_wave_s = 0.0;
  /// Memory bound of a wave's least-squares runs (LM): each holds its candidates' residual vectors
  /// and its solver's dense Jacobian, estimated as least_squares_run_bytes(); runs join a wave
  /// while their sum stays within this (at least one run). 0 = a quarter of the machine's memory.
  std::size_t max_wave_residual_bytes = 0;
  /// Called after each wave: its runs, candidates per round (first round), the target it was
  /// built for and its wall time. For tests; may be empty.
  std::function<void(std::size_t runs, std::size_t candidates, std::size_t target, double wall_s)>
      wave_finished;
  /// Called after each lock-step round; may be empty.
  RoundCallback round_finished;
};

/// What one least-squares run holds (bytes) on a problem of `dimension` parameters whose residual
/// vector has `residual_count` entries: 6 (d + 1) residual vectors, its batch's and its solver's
/// Jacobian with their copies (measured: an LM run on the 2.4 h paper flight, d = 4, 1.72 million
/// residuals, holds 388 MB more than a Nelder-Mead run, about 28 such vectors).
std::size_t least_squares_run_bytes(int dimension, int residual_count);

/// Runs lists of runs of one campaign in lock-step waves, preparing scenarios on first use.
class LockstepRunner {
 public:
  /// `runs` is the campaign's whole run list; `skipped_runs` were done before, `runs_to_do` is
  /// how many this process expects to do (for the progress counts and ETA).
  LockstepRunner(const CampaignConfig& config, RunnerSettings settings,
                 const std::vector<RunSpec>& runs, int skipped_runs, int runs_to_do);
  ~LockstepRunner();
  LockstepRunner(const LockstepRunner&) = delete;
  LockstepRunner& operator=(const LockstepRunner&) = delete;

  /// Runs `ids` (positions in the run list) in waves of consecutive runs of one scenario of
  /// about `wave_target` candidates per round (within the wall-time bound, rounded to the
  /// nearest whole number of two-vector groups for every thread; a tail of the scenario's runs
  /// under a quarter of that joins the last wave). A failed run is recorded and the others go on.
  void run(const std::vector<std::size_t>& ids, std::size_t wave_target, OptimumSource source);

  /// Runs finished and written so far.
  int new_runs() const;
  /// The failed run's error ("" when none failed); when several failed, all of them, one a line.
  std::string first_error() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Candidates per round a wave aims for: three kernel groups of 16 per thread at least, an
/// eighth of the runs to do (at a typical population of 20) at most, so that a killed campaign
/// keeps the waves it finished.
std::size_t wave_target(int threads, std::size_t runs_to_do);

/// Dataset of a scenario spec (simulated deterministically, on `threads` threads, or loaded).
std::shared_ptr<const Dataset> scenario_dataset(const ScenarioSpec& spec, int threads = 1);

}  // namespace insid::campaign
