#include "bench/lockstep_runner.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>
#include <utility>

#include "core/json_reader.h"
#include "core/output_dir.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/uncertainty.h"
#include "optimizers/registry.h"
#include "scenarios/scenario.h"

namespace insid::campaign {
namespace fs = std::filesystem;

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
      std::vector<Member> wave;
      std::size_t wave_candidates = 0;
      while (next < ids.size() && runs_[ids[next]].scenario == scenario &&
             (wave.empty() || wave_candidates < wave_target)) {
        add_member(ids[next], wave, wave_candidates);
        ++next;
      }
      run_wave(wave, *states_[scenario].problem);
    }
  }

  int new_runs() const { return done_; }

  std::string first_error() const {
    for (const auto& [id, error] : errors_) {
      try {
        std::rethrow_exception(error);
      } catch (const std::exception& e) {
        return "run " + runs_[id].path + " failed: " + e.what();
      }
    }
    return "";
  }

 private:
  struct ScenarioState {
    std::shared_ptr<const Dataset> dataset;
    std::shared_ptr<const NavigationProblem> navigation;
    std::unique_ptr<InsIdentificationProblem> problem;
    std::optional<ReferenceOptimum> optimum;
  };
  struct Member {
    std::size_t id;  // position in the run list
    std::unique_ptr<opt::Optimizer> optimizer;
  };

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
  void prepare(std::size_t s, OptimumSource source) {
    const ScenarioSpec& spec = config_.scenarios[s];
    ScenarioState& st = states_[s];
    if (!st.problem) {
      report({.kind = ProgressEvent::Kind::kPreparingScenario, .scenario = spec.name});
      st.dataset = scenario_dataset(spec);
      st.navigation = std::make_shared<const NavigationProblem>(
          st.dataset, NavigationOptions{config_.alignment});
      opt::EvaluatorOptions eval;
      eval.parallelism = opt::Parallelism::kOpenMP;
      eval.num_threads = settings_.threads;
      st.problem = std::make_unique<InsIdentificationProblem>(
          st.navigation, mapping_, FitnessKind::kEq15, eval,
          settings_.scalar_reference ? FitnessEvaluator::kScalar : FitnessEvaluator::kBatched);
    }
    if (st.optimum) return;
    st.optimum = read_optimum(s);
    if (st.optimum || source == OptimumSource::kWait) return;
    report({.kind = ProgressEvent::Kind::kFindingOptimum, .scenario = spec.name});
    // Deterministic: shards that find it at the same time write the same file (atomically).
    st.optimum = find_reference_optimum(*st.problem);
    nlohmann::json oj = st.optimum->to_json(mapping_);
    oj["scenario"] = spec.name;
    fs::create_directories(optimum_path(s).parent_path());
    write_file_atomic(optimum_path(s), oj.dump(2) + "\n");
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
    rc.record_positions = static_cast<int>(
        std::find(config_.seeds.begin(), config_.seeds.end(), run.seed) - config_.seeds.begin()) <
        config_.record_positions_seeds;
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

  void add_member(std::size_t id, std::vector<Member>& wave, std::size_t& wave_candidates) {
    const RunSpec& run = runs_[id];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    try {
      auto optimizer = opt::make_optimizer(
          algo.name, states_[run.scenario].problem->bounds(), run_config(run),
          opt::ParameterMap(algo.parameters.begin(), algo.parameters.end()));
      if (!takes_own_step(*optimizer) && residual_consumer(*optimizer) == nullptr)
        wave_candidates += optimizer->ask().size();
      wave.push_back({id, std::move(optimizer)});
    } catch (...) {
      errors_[id] = std::current_exception();
    }
  }

  // Runs advance in lock-step (issue 6) through opt::run_together: the runs of a wave ask for
  // their next batch together, the batches are scored in one evaluate_batch call (the batched
  // kernel spreads groups of candidates over the threads; least-squares runs' residual batches
  // likewise, in one evaluate_residual_batch call), and each run is told its slice. A run's
  // result depends only on its own fitness values, which do not depend on how candidates are
  // grouped, so results equal separate runs, whatever the waves, shards or ranks. Each run's
  // file is written as soon as the run is done; a failed run is recorded, the others go on.
  void run_wave(std::vector<Member>& wave, const InsIdentificationProblem& problem) {
    std::vector<opt::Optimizer*> optimizers;
    for (Member& m : wave) optimizers.push_back(m.optimizer.get());
    opt::TogetherHooks hooks;
    hooks.finished = [&](std::size_t i) {
      write_run(runs_[wave[i].id], *wave[i].optimizer);
    };
    hooks.failed = [&](std::size_t i, std::exception_ptr error) { errors_[wave[i].id] = error; };
    opt::run_together(optimizers, problem, hooks);
  }

  void write_run(const RunSpec& run, const opt::Optimizer& optimizer) {
    const opt::Result& result = optimizer.result();
    const ScenarioSpec& scenario = config_.scenarios[run.scenario];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    const ReferenceOptimum& opt = optimum(run.scenario);
    nlohmann::json j;
    j["schema"] = kRunSchema;
    j["scenario"] = scenario.name;
    j["algorithm"] = algo.label;
    j["seed"] = run.seed;
    j["parameters"] = nlohmann::json::array();
    for (const EstimatedParameter& p : mapping_.parameters()) j["parameters"].push_back({{"name", p.name}});
    j["result"] = optimizer_result_json(result, mapping_);
    // How sure the estimate is, as in identify results (issue 15): "parameters" with sd and
    // flags, "correlation", "uncertainty" (its wall time and INS runs: the cost per run).
    if (config_.uncertainty_replicas > 0) {
      UncertaintyOptions uo;
      uo.replicas = config_.uncertainty_replicas;
      uo.criterion = criterion_for_algorithm(algo.name);
      uo.threads = settings_.threads;
      add_run_uncertainty_json(j, *states_[run.scenario].problem, optimizer, uo);
    }
    add_run_assessment_json(j, result, mapping_, states_[run.scenario].dataset->meta.injected, &opt);
    fs::create_directories(fs::path(run.path).parent_path());
    write_file_atomic(run.path, j.dump(1) + "\n");
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
  const std::vector<RunSpec>& runs_;
  const ParameterMapping mapping_;
  std::vector<ScenarioState> states_;
  std::map<std::size_t, std::exception_ptr> errors_;  // by position in the run list
  int done_ = 0;
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

std::shared_ptr<const Dataset> scenario_dataset(const ScenarioSpec& spec) {
  if (!spec.data_dir.empty()) return std::make_shared<const Dataset>(load_dataset(spec.data_dir));
  scenarios::ScenarioOverrides overrides;
  overrides.seed = spec.data_seed;
  overrides.grade = spec.grade;
  overrides.flight_s = spec.flight_s;
  overrides.set = spec.set;
  return std::make_shared<const Dataset>(scenarios::simulate_preset(spec.preset, overrides));
}

std::size_t wave_target(int threads, std::size_t runs_to_do) {
  return std::max<std::size_t>(48 * static_cast<std::size_t>(threads), 20 * runs_to_do / 8);
}

}  // namespace insid::campaign
