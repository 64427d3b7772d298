// insid-microbench: Google Benchmark micro-benchmarks of the fitness kernel (and, as they
// arrive, the optimizers' own overhead). Run: build/bench/insid-microbench
//   --benchmark_out=results/perf/microbench.json --benchmark_out_format=json
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include <benchmark/benchmark.h>

#include "core/batch_fitness.h"
#include "core/fitness.h"
#include "core/static_dataset.h"
#include "optimizers/registry.h"

namespace insid {
namespace {

// One hour of 100 Hz data (600 s static alignment + 3000 s navigated), the paper's errors.
std::shared_ptr<const Dataset> one_hour_dataset() {
  static const std::shared_ptr<const Dataset> ds = [] {
    const double lat = 40.068 * kDegToRad;
    SensorErrors errors;
    errors.accel.bias = Eigen::Vector3d(-2.0, 1.5, 0.0) * kSigmaAccelMps2;
    errors.gyro.bias = Eigen::Vector3d(2.0, -1.5, 0.0) * kSigmaGyroRadS;
    return std::make_shared<const Dataset>(
        make_static_dataset(EarthModel::paper(lat, 50.0), lat, 116.246 * kDegToRad, 50.0,
                            {0.01, -0.02, 1.2}, 3600.0, 600.0, errors, 100.0, 100.0));
  }();
  return ds;
}

std::shared_ptr<const NavigationProblem> one_hour_problem() {
  static const auto problem = std::make_shared<const NavigationProblem>(one_hour_dataset());
  return problem;
}

// K candidates near the paper's errors (the paper's four parameters varied).
std::vector<SensorErrors> candidates(int k) {
  std::vector<SensorErrors> out(static_cast<std::size_t>(k));
  for (int i = 0; i < k; ++i) {
    const double u = (i + 0.5) / k - 0.5;
    SensorErrors& c = out[static_cast<std::size_t>(i)];
    c.accel.bias.x() = (-1.9 + u) * kSigmaAccelMps2;
    c.accel.bias.y() = (1.4 - u) * kSigmaAccelMps2;
    c.gyro.bias.x() = (2.1 + 0.5 * u) * kSigmaGyroRadS;
    c.gyro.bias.y() = (-1.4 + 0.7 * u) * kSigmaGyroRadS;
  }
  return out;
}

// ns per candidate per IMU step from wall time (the batched runs use OpenMP threads).
void set_counters(benchmark::State& state, double candidate_steps) {
  state.counters["ns_per_candidate_step"] =
      benchmark::Counter(candidate_steps * 1e-9, benchmark::Counter::kIsIterationInvariantRate |
                                                     benchmark::Counter::kInvert);
  state.counters["steps"] = static_cast<double>(one_hour_problem()->num_steps());
}

// One full fitness evaluation (alignment + navigation + Eq. 15) with the scalar reference.
void BM_FitnessScalar(benchmark::State& state) {
  const NavigationProblem& problem = *one_hour_problem();
  SensorErrors candidate;
  candidate.accel.bias.x() = -1.9 * kSigmaAccelMps2;
  candidate.gyro.bias.y() = -1.4 * kSigmaGyroRadS;
  for (auto _ : state) benchmark::DoNotOptimize(problem.fitness(candidate));
  set_counters(state, static_cast<double>(problem.num_steps()));
}
BENCHMARK(BM_FitnessScalar)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();

// K candidates with the batched kernel (core/batch_fitness.h), Eq. 15, on `threads` threads:
// state.range(0) = K, state.range(1) = threads.
void BM_FitnessBatched(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const auto kernel = BatchFitness::shared(one_hour_problem());
  const std::vector<SensorErrors> c = candidates(k);
  std::vector<double> f;
  for (auto _ : state) {
    f = kernel->fitness(c, FitnessKind::kEq15, threads);
    benchmark::DoNotOptimize(f.data());
  }
  set_counters(state,
               static_cast<double>(k) * static_cast<double>(one_hour_problem()->num_steps()));
  state.counters["threads"] = threads;
}
BENCHMARK(BM_FitnessBatched)
    ->ArgNames({"K", "threads"})
    ->ArgsProduct({{8, 16, 24, 32}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();

// The windowed fitness (issue 14) next to the one-run fitness in the same run: the same hour of
// data and candidates, state.range(2) = W in seconds (0 = one run). The restarts (one per W of
// data, shared by all lanes) must keep the kernel's lock-step speed.
std::shared_ptr<const NavigationProblem> one_hour_problem_windowed(int window_s) {
  static std::mutex mutex;
  static std::map<int, std::shared_ptr<const NavigationProblem>> problems;
  std::lock_guard<std::mutex> lock(mutex);
  auto& problem = problems[window_s];
  if (!problem) {
    NavigationOptions options;
    options.window_s = window_s;
    problem = std::make_shared<const NavigationProblem>(one_hour_dataset(), options);
  }
  return problem;
}

void BM_FitnessBatchedWindowed(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const auto problem = one_hour_problem_windowed(static_cast<int>(state.range(2)));
  const auto kernel = BatchFitness::shared(problem);
  const std::vector<SensorErrors> c = candidates(k);
  std::vector<double> f;
  for (auto _ : state) {
    f = kernel->fitness(c, FitnessKind::kEq15, threads);
    benchmark::DoNotOptimize(f.data());
  }
  set_counters(state, static_cast<double>(k) * static_cast<double>(problem->num_steps()));
  state.counters["threads"] = threads;
  state.counters["windows"] = static_cast<double>(problem->num_windows());
}
BENCHMARK(BM_FitnessBatchedWindowed)
    ->ArgNames({"K", "threads", "W"})
    ->ArgsProduct({{16, 32}, {1, 2}, {0, 10, 60}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();

// The optimizers' own cost per generation (ask + tell), fitness excluded: a 4-D problem whose
// fitness is a precomputed constant-time sphere, Table 4 settings. Shows the harness's overhead
// next to the fitness cost above (one paper-flight fitness evaluation is ~6 ms batched).
void BM_OptimizerGeneration(benchmark::State& state, const char* algorithm) {
  std::int64_t generations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    opt::RunConfig config;
    config.seed = 7;
    config.max_iterations = 40;
    auto optimizer = opt::make_optimizer(algorithm, opt::Bounds::unit_box(4), config);
    std::vector<double> f;
    state.ResumeTiming();
    while (!optimizer->done()) {
      const auto batch = optimizer->ask();
      f.resize(batch.size());
      for (std::size_t i = 0; i < batch.size(); ++i) f[i] = batch[i].squaredNorm();
      optimizer->tell(f);
      ++generations;
    }
  }
  state.counters["ns_per_generation"] =
      benchmark::Counter(static_cast<double>(generations) * 1e-9,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK_CAPTURE(BM_OptimizerGeneration, ga, "ga");
BENCHMARK_CAPTURE(BM_OptimizerGeneration, pso, "pso");
BENCHMARK_CAPTURE(BM_OptimizerGeneration, pio, "pio");
BENCHMARK_CAPTURE(BM_OptimizerGeneration, dvpio, "dvpio");

}  // namespace
}  // namespace insid

BENCHMARK_MAIN();
