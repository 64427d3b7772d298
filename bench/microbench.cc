// insid-microbench: Google Benchmark micro-benchmarks of the fitness kernel (and, as they
// arrive, the optimizers' own overhead). Run: build/bench/insid-microbench
//   --benchmark_out=results/perf/microbench.json --benchmark_out_format=json
#include <memory>

#include <benchmark/benchmark.h>

#include "core/fitness.h"
#include "core/test_support.h"

namespace insid {
namespace {

// One hour of 100 Hz data (600 s static alignment + 3000 s navigated), the paper's errors.
std::shared_ptr<const Dataset> one_hour_dataset() {
  static const std::shared_ptr<const Dataset> ds = [] {
    const double lat = 40.068 * kDegToRad;
    SensorErrors errors;
    errors.accel.bias = Eigen::Vector3d(-2.0, 1.5, 0.0) * kSigmaAccelMps2;
    errors.gyro.bias = Eigen::Vector3d(2.0, -1.5, 0.0) * kSigmaGyroRadS;
    return std::make_shared<const Dataset>(testing::make_static_dataset(
        EarthModel::paper(lat, 50.0), lat, 116.246 * kDegToRad, 50.0,
        {0.01, -0.02, 1.2}, 3600.0, 600.0, errors, 100.0, 100.0));
  }();
  return ds;
}

// One full fitness evaluation (alignment + navigation + Eq. 15) with the scalar reference.
void BM_FitnessScalar(benchmark::State& state) {
  const NavigationProblem problem(one_hour_dataset());
  SensorErrors candidate;
  candidate.accel.bias.x() = -1.9 * kSigmaAccelMps2;
  candidate.gyro.bias.y() = -1.4 * kSigmaGyroRadS;
  for (auto _ : state) benchmark::DoNotOptimize(problem.fitness(candidate));
  const double steps = static_cast<double>(problem.num_steps());
  state.counters["ns_per_candidate_step"] = benchmark::Counter(
      steps * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["steps"] = steps;
}
BENCHMARK(BM_FitnessScalar)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace
}  // namespace insid

BENCHMARK_MAIN();
