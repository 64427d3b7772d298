#include "bench/lockstep_runner.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <future>
#include <limits>
#include <map>
#include <optional>
#include <thread>
#include <utility>

#include <unistd.h>

#include "base/json_reader.h"
#include "base/output_dir.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/search_fitness.h"
#include "identification/uncertainty.h"
#include "kernel/batch_fitness.h"
#include "optimizers/external.h"
#include "optimizers/fitness_memo.h"
#include "optimizers/registry.h"
#include "scenarios/scenario.h"

namespace insid::campaign {
namespace fs = std::filesystem;

// An external optimizer's first batch, counted towards a wave's size before it is asked (the
// reference client's batch is 10).
constexpr std::size_t kExternalCandidatesGuess = 10;

std::size_t least_squares_run_bytes(int dimension, int residual_count) {
  return 6 * (static_cast<std::size_t>(dimension) + 1) * static_cast<std::size_t>(residual_count) *
         sizeof(double);
}

namespace {
// A quarter of the machine's memory: 31 LM runs of the paper flight (about 12 GB) in one wave
// were killed by the kernel's out-of-memory killer on a 24 GiB machine.
std::size_t default_wave_residual_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return std::size_t{4} << 30;
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page) / 4;
}
}  // namespace

struct LockstepRunner::Impl {
 public:
  Impl(const CampaignConfig& config, RunnerSettings settings, const std::vector<RunSpec>& runs,
       int skipped_runs, int runs_to_do)
      : config_(config),
        settings_(std::move(settings)),
        runs_(runs),
        mapping_(estimated_parameters(config)),
        states_(config.scenarios.size()),
        skipped_runs_(skipped_runs),
        runs_to_do_(runs_to_do),
        t_start_(std::chrono::steady_clock::now()) {}

  void run(const std::vector<std::size_t>& ids, std::size_t wave_target, OptimumSource source) {
    std::size_t next = 0;
    while (next < ids.size()) {
      const std::size_t scenario = runs_[ids[next]].scenario;
      prepare(scenario, source);
      ScenarioState& st = states_[scenario];
      const std::size_t target = bounded_wave_target(wave_target, st.seconds_per_candidate);
      const std::size_t cap = filled_groups_cap(target);
      // Runs join while the wave's first round fits under the cap and its least-squares runs
      // within the memory bound; the run that would overflow either is made again as the first
      // of the next wave (unless it would be alone here).
      std::vector<Member> wave;
      WaveSize size;
      while (next < ids.size() && runs_[ids[next]].scenario == scenario && size.candidates < cap &&
             size.residual_bytes < residual_cap_) {
        const WaveSize before = size;
        const std::size_t members = wave.size();
        add_member(ids[next], wave, size);
        if (members > 0 && wave.size() > members &&
            (size.candidates > cap || size.residual_bytes > residual_cap_)) {
          wave.pop_back();
          size = before;
          break;
        }
        ++next;
      }
      // A tail of the scenario's runs smaller than a quarter of the cap (by this wave's
      // candidates per run) joins this wave instead of running alone on a few threads, unless
      // the wave holds least-squares runs (the memory bound).
      std::size_t tail_runs = 0;
      for (std::size_t i = next; i < ids.size() && runs_[ids[i]].scenario == scenario; ++i)
        ++tail_runs;
      if (!wave.empty() && tail_runs > 0 && size.residual_bytes == 0 &&
          static_cast<double>(tail_runs * size.candidates) <=
              0.25 * static_cast<double>(cap * wave.size())) {
        while (next < ids.size() && runs_[ids[next]].scenario == scenario)
          add_member(ids[next++], wave, size);
      }
      const std::size_t wave_candidates = size.candidates;
      const auto t_wave = std::chrono::steady_clock::now();
      run_wave(wave, *st.search, st.memo);
      const double wave_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_wave).count();
      // The speed of this wave sizes the next one of the scenario (waves of bounded wall time).
      if (wave_candidates > 0)
        st.seconds_per_candidate = wave_s / static_cast<double>(wave_candidates);
      if (settings_.wave_finished)
        settings_.wave_finished(wave.size(), wave_candidates, target, wave_s);
      write_parked_runs();
      // The scenario's last wave: its memo is not needed any more (a campaign of many scenarios
      // would otherwise keep up to two generations of candidates for each).
      if (next >= ids.size() || runs_[ids[next]].scenario != scenario) st.memo = opt::FitnessMemo();
    }
    // The optima found alongside: wait for them, then write the runs that waited for them.
    for (std::size_t s = 0; s < states_.size(); ++s)
      if (states_[s].optimum_future.valid()) collect_optimum(s);
    write_parked_runs();
  }

  int new_runs() const { return done_; }

  // One failed run: "run PATH failed: why"; several: "N of M runs failed (...)" and each one.
  std::string first_error() const {
    std::vector<std::string> failures;
    for (const auto& [id, error] : errors_) {
      try {
        std::rethrow_exception(error);
      } catch (const std::exception& e) {
        failures.push_back("run " + runs_[id].path + " failed: " + e.what());
      }
    }
    if (failures.size() <= 1) return failures.empty() ? "" : failures.front();
    std::string text = std::to_string(failures.size()) + " of " + std::to_string(runs_.size()) +
                       " runs failed (the others were written):";
    for (const std::string& failure : failures) text += "\n  " + failure;
    return text;
  }

 private:
  struct ScenarioState {
    std::shared_ptr<const Dataset> dataset;
    std::shared_ptr<const NavigationProblem> navigation;
    std::unique_ptr<InsIdentificationProblem> problem;
    /// What the optimizers are scored with (the fast search fitness or `problem` itself);
    /// `problem`, the exact kernel, scores every reported number.
    std::unique_ptr<SearchProblem> search;
    std::optional<ReferenceOptimum> optimum;
    /// The optimum being found alongside the runs, on its own single-threaded problem.
    std::unique_ptr<InsIdentificationProblem> optimum_problem;
    std::future<ReferenceOptimum> optimum_future;
    /// Finished runs waiting for the optimum before their files can be written.
    struct Parked {
      std::size_t id;  // position in the run list
      opt::Result result;
      nlohmann::json uncertainty;  // the run's uncertainty blocks, computed when it finished
      double search_best_f;        // the search fitness of the best point (result.best_f: exact)
    };
    std::vector<Parked> parked;
    /// Wall seconds per candidate-per-round of the scenario's last wave (0: none yet).
    double seconds_per_candidate = 0.0;
    /// Noise replicas for the runs' uncertainty: run once per scenario at the data's
    /// optimum, shared by every run (each run adds only its own Jacobian).
    std::optional<NoiseReplicaSet> replicas;
    /// Fitness of every candidate scored in the scenario's waves (bounded, opt::FitnessMemo):
    /// a candidate asked again, in the same wave or a later one, is not scored again. Runs with
    /// the same seed share their first iterations (PIO and DVPIO move by the same Eq. 8-9 draws
    /// until DVPIO turns premature), and a GA child that was neither crossed nor mutated is its
    /// parent.
    opt::FitnessMemo memo;
  };
  struct Member {
    std::size_t id;  // position in the run list
    std::unique_ptr<opt::Optimizer> optimizer;
  };

  // A file at one of the campaign's own paths (its directory accepted by prepare_directory,
  // bench/campaign.cc), written without following links below it: a runs/ or optimum/ planted
  // as a link to elsewhere is refused (base/output_dir.h). A file already there is replaced
  // (a damaged run being redone), a link never.
  void write_in_campaign(const fs::path& path, const std::string& text) const {
    WriteOptions options;
    options.create_directories = true;
    options.replace_foreign = true;
    write_file_atomic_under(settings_.out_dir, path.lexically_relative(settings_.out_dir), text,
                            options);
  }

  fs::path optimum_path(std::size_t s) const {
    return optimum_file(settings_.out_dir, config_.scenarios[s].name);
  }

  std::optional<ReferenceOptimum> read_optimum(std::size_t s) const {
    const fs::path path = optimum_path(s);
    std::error_code ec;
    if (!fs::exists(path, ec)) return std::nullopt;
    try {
      return ReferenceOptimum::from_json(read_json_file(path), mapping_);
    } catch (const std::exception&) {
      return std::nullopt;  // damaged: find it again
    }
  }

  // Dataset, problem and (unless another rank finds it) the data's own optimum of scenario s.
  // A campaign's run is identify's (the default set and the gyro bias allowance are identify's
  // rules, through estimated_parameters and navigation_options; the run file's assessment is
  // add_run_assessment_json's), but not a call of identify(spec): its runs share one problem,
  // optimum and noise-replica set per scenario and are scored together in waves (run_wave),
  // which one run at a time cannot do.
  void prepare(std::size_t s, OptimumSource source) {
    const ScenarioSpec& spec = config_.scenarios[s];
    ScenarioState& st = states_[s];
    if (!st.problem) {
      report({.kind = ProgressEvent::Kind::kPreparingScenario, .scenario = spec.name});
      st.dataset = scenario_dataset(spec, settings_.threads);
      st.navigation =
          std::make_shared<const NavigationProblem>(st.dataset, config_.navigation_options());
      opt::EvaluatorOptions eval;
      eval.parallelism = opt::Parallelism::kOpenMP;
      eval.num_threads = settings_.threads;
      st.problem = std::make_unique<InsIdentificationProblem>(
          st.navigation, mapping_, FitnessKind::kEq15, eval,
          settings_.scalar_reference ? FitnessEvaluator::kScalar : FitnessEvaluator::kBatched);
      st.search = std::make_unique<SearchProblem>(*st.problem, config_.search_fitness);
    }
    if (st.optimum || st.optimum_future.valid()) return;
    st.optimum = read_optimum(s);
    if (st.optimum || source == OptimumSource::kWait) return;
    report({.kind = ProgressEvent::Kind::kFindingOptimum, .scenario = spec.name});
    // Alongside the runs, which do not need it (only their files' error_vs_optimum block does):
    // one more thread beside the OpenMP team, on its own problem. Its starts run in lock-step,
    // one batch a round (local_fits), scored on up to a quarter as many threads as the team (at
    // 16 threads the optimum on one thread would outlast the runs), on one at 2 threads. The
    // kernel gives the same bits for any thread count, so the optimum equals one found first.
    const int optimum_threads = std::clamp(settings_.threads / 4, 1, 4);
    opt::EvaluatorOptions beside;
    beside.parallelism =
        optimum_threads > 1 ? opt::Parallelism::kOpenMP : opt::Parallelism::kSerial;
    beside.num_threads = optimum_threads;
    st.optimum_problem = std::make_unique<InsIdentificationProblem>(
        st.navigation, mapping_, FitnessKind::kEq15, beside,
        settings_.scalar_reference ? FitnessEvaluator::kScalar : FitnessEvaluator::kBatched);
    st.optimum_future =
        std::async(std::launch::async, [problem = st.optimum_problem.get(), optimum_threads] {
          return find_reference_optimum(*problem, kReferenceOptimumStarts, kReferenceOptimumSeed,
                                        optimum_threads);
        });
  }

  // Waits for the optimum found alongside and writes its file. Deterministic: shards that find
  // it at the same time write the same file (atomically).
  void collect_optimum(std::size_t s) {
    ScenarioState& st = states_[s];
    st.optimum = st.optimum_future.get();
    st.optimum_problem.reset();
    nlohmann::json oj = st.optimum->to_json(mapping_);
    oj["scenario"] = config_.scenarios[s].name;
    write_in_campaign(optimum_path(s), oj.dump(2) + "\n");
  }

  // Scenario s's optimum, waiting for the one being found alongside if need be (collecting it:
  // optimum() alone would wait for a file that only collect_optimum writes).
  const ReferenceOptimum& optimum_now(std::size_t s) {
    ScenarioState& st = states_[s];
    if (!st.optimum && st.optimum_future.valid()) collect_optimum(s);
    return optimum(s);
  }

  // Whether scenario s's optimum is known now (collecting it when found alongside).
  bool optimum_ready(std::size_t s) {
    ScenarioState& st = states_[s];
    if (st.optimum) return true;
    if (st.optimum_future.valid() &&
        st.optimum_future.wait_for(std::chrono::seconds(0)) == std::future_status::ready)
      collect_optimum(s);
    return st.optimum.has_value();
  }

  // Writes the finished runs that waited for an optimum that is known now.
  void write_parked_runs() {
    for (std::size_t s = 0; s < states_.size(); ++s) {
      if (states_[s].parked.empty() || !optimum_ready(s)) continue;
      std::vector<ScenarioState::Parked> parked;
      parked.swap(states_[s].parked);
      for (const auto& r : parked) write_run(runs_[r.id], r.result, r.uncertainty, r.search_best_f);
    }
  }

  // The wave target within the wall-time bound: the scenario's first wave is the smallest that
  // keeps the kernel's groups full (its speed is not known yet), later ones as many candidates
  // per round as the last wave's speed fits into max_wave_s, never fewer than that smallest.
  std::size_t bounded_wave_target(std::size_t target, double seconds_per_candidate) const {
    if (settings_.max_wave_s <= 0.0) return target;
    const std::size_t smallest = wave_target(settings_.threads, 0);
    if (seconds_per_candidate <= 0.0) return std::min(target, smallest);
    const double fits = settings_.max_wave_s / seconds_per_candidate;
    const std::size_t bounded =
        fits >= static_cast<double>(target) ? target : static_cast<std::size_t>(fits);
    return std::min(target, std::max(smallest, bounded));
  }

  // The candidates a round of a wave may hold: the target rounded to the nearest whole number
  // of two-vector groups for every thread (kLanes x planned_chains() x threads candidates, 16 x
  // threads on the AVX-512 path; the smallest wave, 48 x threads, is three). A round that
  // overshoots such a multiple by a few candidates leaves every thread but one waiting for that
  // one's extra group (results/perf/README.md, "Round by round").
  std::size_t filled_groups_cap(std::size_t target) const {
    const std::size_t unit = static_cast<std::size_t>(BatchFitness::kLanes) *
                             static_cast<std::size_t>(BatchFitness::planned_chains()) *
                             static_cast<std::size_t>(std::max(settings_.threads, 1));
    if (target >= std::numeric_limits<std::size_t>::max() - unit) return target;  // no bound
    return std::max(unit, (target + unit / 2) / unit * unit);
  }

  // The optimum of scenario s, waiting for the MPI rank that finds it when it is not there yet.
  const ReferenceOptimum& optimum(std::size_t s) {
    ScenarioState& st = states_[s];
    bool said = false;
    while (!st.optimum) {
      st.optimum = read_optimum(s);
      if (st.optimum) break;
      if (!said)
        report({.kind = ProgressEvent::Kind::kWaitingForOptimum, .path = optimum_path(s).string()});
      said = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return *st.optimum;
  }

  opt::RunConfig run_config(const RunSpec& run) const {
    opt::RunConfig rc;
    rc.seed = run.seed;
    rc.max_iterations = config_.max_iterations;
    rc.max_evaluations = config_.max_evaluations;
    rc.record_positions =
        static_cast<int>(std::find(config_.seeds.begin(), config_.seeds.end(), run.seed) -
                         config_.seeds.begin()) < config_.record_positions_seeds;
    return rc;
  }

  // Kalman-type baselines see the problem and score their own candidates.
  static bool takes_own_step(const opt::Optimizer& optimizer) {
    return dynamic_cast<const opt::ProblemConsumer*>(&optimizer) != nullptr;
  }
  // Least-squares baselines need the residual vectors of their candidates.
  static opt::ResidualConsumer* residual_consumer(opt::Optimizer& optimizer) {
    return dynamic_cast<opt::ResidualConsumer*>(&optimizer);
  }

  // What a wave holds: candidates of its first round, and its least-squares runs' memory.
  struct WaveSize {
    std::size_t candidates = 0;
    std::size_t residual_bytes = 0;
  };

  void add_member(std::size_t id, std::vector<Member>& wave, WaveSize& size) {
    const RunSpec& run = runs_[id];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    try {
      auto optimizer =
          opt::make_optimizer(algo.name, states_[run.scenario].problem->bounds(), run_config(run),
                              opt::ParameterMap(algo.parameters.begin(), algo.parameters.end()));
      if (auto* external = dynamic_cast<opt::ExternalOptimizer*>(optimizer.get())) {
        // Started now, asked later with the wave: the processes of a wave start together
        // (each run's result depends only on its own fitness values, so the wave
        // does not change it). Its batch size is unknown until it replies: counted as
        // kExternalCandidatesGuess for the wave's size.
        external->launch();
        size.candidates += kExternalCandidatesGuess;
      } else if (residual_consumer(*optimizer) != nullptr) {
        const SearchProblem& problem = *states_[run.scenario].search;
        size.residual_bytes +=
            least_squares_run_bytes(problem.dimension(), problem.residual_count());
      } else if (!takes_own_step(*optimizer)) {
        size.candidates += optimizer->ask().size();
      }
      wave.push_back({id, std::move(optimizer)});
    } catch (...) {
      errors_[id] = std::current_exception();
    }
  }

  // Runs advance in lock-step through opt::run_together: the runs of a wave ask for
  // their next batch together, the batches are scored in one evaluate_batch call (the batched
  // kernel spreads groups of candidates over the threads; least-squares runs' residual batches
  // likewise, in one evaluate_residual_batch call), and each run is told its slice. A run's
  // result depends only on its own fitness values, which do not depend on how candidates are
  // grouped, so results equal separate runs, whatever the waves, shards or ranks. Each run's
  // file is written as soon as the run is done; a failed run is recorded, the others go on.
  //
  // The search fitness steers the runs; when the wave is done, the exact kernel scores every
  // finished run's best point in one batch, and that is the run's reported best_f (the search's
  // value is kept beside it).
  void run_wave(std::vector<Member>& wave, const SearchProblem& problem, opt::FitnessMemo& memo) {
    std::vector<opt::Optimizer*> optimizers;
    for (Member& m : wave) optimizers.push_back(m.optimizer.get());
    std::vector<std::size_t> finished;
    opt::TogetherHooks hooks;
    hooks.finished = [&](std::size_t i) { finished.push_back(i); };
    hooks.failed = [&](std::size_t i, std::exception_ptr error) { errors_[wave[i].id] = error; };
    if (settings_.round_finished) {
      hooks.round_done = [&](std::size_t candidates, std::size_t scored, double scoring_s,
                             double round_s) {
        settings_.round_finished({.wave = waves_,
                                  .wave_runs = wave.size(),
                                  .candidates = candidates,
                                  .scored = scored,
                                  .scoring_s = scoring_s,
                                  .round_s = round_s});
      };
    }
    opt::run_together(optimizers, problem, hooks, &memo);
    ++waves_;
    if (finished.empty()) return;
    std::vector<Eigen::VectorXd> best;
    for (std::size_t i : finished) best.push_back(wave[i].optimizer->result().best_x);
    std::vector<double> exact(best.size());
    std::vector<std::exception_ptr> failed(best.size());
    try {
      exact = problem.exact_fitness(best);
    } catch (...) {  // one at a time, to tell which run's best point the exact kernel refuses
      for (std::size_t n = 0; n < best.size(); ++n) try {
          exact[n] = problem.exact_fitness(std::span(&best[n], 1)).front();
        } catch (...) {
          failed[n] = std::current_exception();
        }
    }
    for (std::size_t n = 0; n < finished.size(); ++n) {
      const std::size_t i = finished[n];
      if (failed[n]) {
        errors_[wave[i].id] = failed[n];
        continue;
      }
      const RunSpec& run = runs_[wave[i].id];
      ScenarioState& st = states_[run.scenario];
      opt::Result result = wave[i].optimizer->result();
      const double search_best_f = result.best_f;
      result.best_f = exact[n];
      nlohmann::json uncertainty = uncertainty_blocks(run, *wave[i].optimizer);
      if (st.optimum_future.valid() && !optimum_ready(run.scenario))
        st.parked.push_back({wave[i].id, std::move(result), std::move(uncertainty), search_best_f});
      else
        write_run(run, result, uncertainty, search_best_f);
    }
  }

  // How sure the run's estimate is, as in identify results: "parameters" with sd and
  // flags, "correlation", "uncertainty" (its wall time and INS runs: the cost per run); empty
  // when the config turns it off. Needs the optimizer (the EKF-RTS reports its own sd).
  // The noise replicas are run once per scenario, at the data's optimum (the first finished
  // run waits for it when it is still being found): they depend on the data and the noise
  // model, not on the run, so every run file's sd comes from the same replicas.
  nlohmann::json uncertainty_blocks(const RunSpec& run, const opt::Optimizer& optimizer) {
    nlohmann::json j = nlohmann::json::object();
    if (config_.uncertainty_replicas > 0) {
      UncertaintyOptions uo;
      uo.replicas = config_.uncertainty_replicas;
      uo.criterion = criterion_for_algorithm(config_.algorithms[run.algorithm].name);
      uo.threads = settings_.threads;
      ScenarioState& st = states_[run.scenario];
      if (!st.replicas)
        st.replicas = noise_replica_set(*st.problem, optimum_now(run.scenario).value_sigma, uo);
      add_run_uncertainty_json(j, *st.problem, optimizer, uo, &*st.replicas);
    }
    return j;
  }

  void write_run(const RunSpec& run, const opt::Result& result, const nlohmann::json& uncertainty,
                 double search_best_f) {
    const ScenarioSpec& scenario = config_.scenarios[run.scenario];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    const ReferenceOptimum& opt = optimum(run.scenario);
    nlohmann::json j;
    j["schema"] = kRunSchema;
    j["scenario"] = scenario.name;
    j["algorithm"] = algo.label;
    j["seed"] = run.seed;
    // Recorded only when the config sets them (older run files stay as they were).
    if (config_.initial_attitude)
      j["initial_attitude"] = insid::to_string(*config_.initial_attitude);
    if (config_.heading_deg) j["heading_deg"] = *config_.heading_deg;
    if (config_.heading_source) j["heading_source"] = insid::to_string(*config_.heading_source);
    if (config_.window_s != 0.0) j["window_s"] = config_.window_s;
    if (config_.estimation_grade) j["estimation_grade"] = *config_.estimation_grade;
    j["parameters"] = nlohmann::json::array();
    for (const EstimatedParameter& p : mapping_.parameters())
      j["parameters"].push_back({{"name", p.name}});
    j["result"] = optimizer_result_json(result, mapping_);
    // Which fitness steered the search (its convergence curves) and which scored best_f.
    const SearchProblem& search = *states_[run.scenario].search;
    j["search_fitness"] = {{"requested", insid::to_string(search.requested())},
                           {"used", search.used()},
                           {"reported", "exact"},
                           {"best_f_search", search_best_f}};
    for (const auto& item : uncertainty.items()) j[item.key()] = item.value();
    add_run_assessment_json(j, result, mapping_, states_[run.scenario].dataset->meta.injected,
                            &opt);
    write_in_campaign(run.path, j.dump(1) + "\n");
    const int n_done = ++done_;
    if (settings_.progress) {
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count();
      report({.kind = ProgressEvent::Kind::kRunFinished,
              .scenario = scenario.name,
              .algorithm = algo.label,
              .seed = run.seed,
              .runs_present = skipped_runs_ + n_done,
              .runs_total = static_cast<int>(runs_.size()),
              .new_runs = n_done,
              .elapsed_s = elapsed,
              .eta_s = elapsed / n_done * (runs_to_do_ - n_done),
              .mpi_rank = settings_.mpi_rank});
    }
  }

  void report(const ProgressEvent& event) const {
    if (settings_.progress) settings_.progress(event);
  }

  const CampaignConfig& config_;
  const RunnerSettings settings_;
  const std::size_t residual_cap_ = settings_.max_wave_residual_bytes > 0
                                        ? settings_.max_wave_residual_bytes
                                        : default_wave_residual_bytes();
  const std::vector<RunSpec>& runs_;
  const ParameterMapping mapping_;
  std::vector<ScenarioState> states_;
  std::map<std::size_t, std::exception_ptr> errors_;  // by position in the run list
  int done_ = 0;
  std::size_t waves_ = 0;  // waves run so far (RoundRecord::wave)
  const int skipped_runs_, runs_to_do_;
  const std::chrono::steady_clock::time_point t_start_;
};
LockstepRunner::LockstepRunner(const CampaignConfig& config, RunnerSettings settings,
                               const std::vector<RunSpec>& runs, int skipped_runs, int runs_to_do)
    : impl_(std::make_unique<Impl>(config, std::move(settings), runs, skipped_runs, runs_to_do)) {}

LockstepRunner::~LockstepRunner() = default;

void LockstepRunner::run(const std::vector<std::size_t>& ids, std::size_t wave_target,
                         OptimumSource source) {
  impl_->run(ids, wave_target, source);
}

int LockstepRunner::new_runs() const { return impl_->new_runs(); }

std::string LockstepRunner::first_error() const { return impl_->first_error(); }

std::shared_ptr<const Dataset> scenario_dataset(const ScenarioSpec& spec, int threads) {
  if (!spec.data_dir.empty()) return std::make_shared<const Dataset>(load_dataset(spec.data_dir));
  scenarios::ScenarioOverrides overrides;
  overrides.seed = spec.data_seed;
  overrides.grade = spec.grade;
  overrides.flight_s = spec.flight_s;
  overrides.set = spec.set;
  return std::make_shared<const Dataset>(scenarios::simulate_preset(
      spec.preset, overrides, /*record_truth_in_meta=*/true, std::max(threads, 1)));
}

std::size_t wave_target(int threads, std::size_t runs_to_do) {
  return std::max<std::size_t>(48 * static_cast<std::size_t>(threads), 20 * runs_to_do / 8);
}

}  // namespace insid::campaign
