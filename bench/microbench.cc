// insid-microbench: Google Benchmark micro-benchmarks of the fitness kernel (and, as they
// arrive, the optimizers' own overhead). Run: build/bench/insid-microbench
//   --benchmark_out=results/perf/microbench.json --benchmark_out_format=json
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include <benchmark/benchmark.h>

#include "data/static_dataset.h"
#include "identification/ins_problem.h"
#include "identification/search_fitness.h"
#include "kernel/batch_fitness.h"
#include "nav/fitness.h"
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

// K candidates with the batched kernel (kernel/batch_fitness.h), Eq. 15, on `threads` threads:
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

// The two search fitnesses (identification/search_fitness.h) on the same K candidates of the
// paper's four parameters, one thread: state.range(0) = K; "exact" is the batched kernel, "fast"
// the second-order model (the ratio of the two is issue 47's speed-up of the scoring itself).
void BM_SearchFitness(benchmark::State& state, SearchFitnessKind kind) {
  const int k = static_cast<int>(state.range(0));
  static const InsIdentificationProblem exact(one_hour_problem(),
                                              ParameterMapping(EstimatedParameter::paper_four()));
  static const FastFitness fast(exact);
  std::vector<Eigen::VectorXd> xs;
  for (int i = 0; i < k; ++i) {
    const double u = (i + 0.5) / k - 0.5;
    xs.push_back(Eigen::Vector4d(-0.45 + u, 0.35 - u, 0.5 + 0.1 * u, -0.3 + 0.2 * u));
  }
  std::vector<double> f(xs.size());
  for (auto _ : state) {
    if (kind == SearchFitnessKind::kFast)
      fast.evaluate(xs, f, 1);
    else
      exact.evaluate_batch(xs, f);
    benchmark::DoNotOptimize(f.data());
  }
  set_counters(state,
               static_cast<double>(k) * static_cast<double>(one_hour_problem()->num_steps()));
}
BENCHMARK_CAPTURE(BM_SearchFitness, exact, SearchFitnessKind::kExact)
    ->ArgNames({"K"})
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_SearchFitness, fast, SearchFitnessKind::kFast)
    ->ArgNames({"K"})
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();

// K candidates with their residual vectors (what Levenberg-Marquardt's Jacobians ask for: the
// optimum of `insid bench`, `insid identify --algorithm lm`), fresh vectors each request as the
// optimizers' bridge hands them over: state.range(0) = K, state.range(1) = threads.
void BM_FitnessBatchedResiduals(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const auto kernel = BatchFitness::shared(one_hour_problem());
  const std::vector<SensorErrors> c = candidates(k);
  std::vector<double> f(c.size());
  for (auto _ : state) {
    std::vector<std::vector<double>> residuals(c.size());
    BatchFitness::Request request;
    request.candidates = c;
    request.fitness = f;
    request.residuals = residuals;
    request.threads = threads;
    kernel->evaluate(request);
    benchmark::DoNotOptimize(residuals.back().data());
  }
  set_counters(state,
               static_cast<double>(k) * static_cast<double>(one_hour_problem()->num_steps()));
  state.counters["threads"] = threads;
}
BENCHMARK(BM_FitnessBatchedResiduals)
    ->ArgNames({"K", "threads"})
    ->ArgsProduct({{8, 16}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0)
    ->UseRealTime();

// The windowed fitness (nav/fitness.h) next to the one-run fitness in the same run: the same hour
// of data and candidates, state.range(2) = W in seconds (0 = one run). The restarts (one per W of
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

// Pipe probes (results/perf/README.md "Compute limit on Zen 5"): what this core
// sustains, measured in the same run as the kernel so that clock and load cancel in the ratios.
// Each iteration runs kProbeBlocks blocks of 12 independent 512-bit FMA chains (12 chains of
// latency 4 keep two FMA pipes busy), alone or with the memory and divider traffic the kernel's
// compiled loop carries per FMA (scripts/kernel_limit.py counts it), so that
// fma_per_ns(mix) x ops per candidate-step gives the limit that mix allows. The probes are
// AVX-512 whatever the program's instruction set (the kernel's path is chosen at run time), and
// skip on a CPU without it.
#if defined(__x86_64__) && defined(__GNUC__)
constexpr std::int64_t kProbeBlocks = 100000;
alignas(64) double probe_buffer[32 * 8];

#define INSID_FMA12                                                               \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm0\n vfmadd231pd %%zmm12, %%zmm13, %%zmm1\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm2\n vfmadd231pd %%zmm12, %%zmm13, %%zmm3\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm4\n vfmadd231pd %%zmm12, %%zmm13, %%zmm5\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm6\n vfmadd231pd %%zmm12, %%zmm13, %%zmm7\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm8\n vfmadd231pd %%zmm12, %%zmm13, %%zmm9\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm10\n vfmadd231pd %%zmm12, %%zmm13, %%zmm11\n"
// 8 of the 12 with a memory operand (the kernel's spill reloads and constants) + 2 more loads.
#define INSID_FMA12_LOAD10                                                              \
  "vfmadd231pd 0(%%rax), %%zmm13, %%zmm0\n vfmadd231pd 64(%%rax), %%zmm13, %%zmm1\n"    \
  "vfmadd231pd 128(%%rax), %%zmm13, %%zmm2\n vfmadd231pd 192(%%rax), %%zmm13, %%zmm3\n" \
  "vfmadd231pd 256(%%rax), %%zmm13, %%zmm4\n vfmadd231pd 320(%%rax), %%zmm13, %%zmm5\n" \
  "vfmadd231pd 384(%%rax), %%zmm13, %%zmm6\n vfmadd231pd 448(%%rax), %%zmm13, %%zmm7\n" \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm8\n vfmadd231pd %%zmm12, %%zmm13, %%zmm9\n"       \
  "vfmadd231pd %%zmm12, %%zmm13, %%zmm10\n vfmadd231pd %%zmm12, %%zmm13, %%zmm11\n"     \
  "vmovapd 512(%%rax), %%zmm16\n vmovapd 576(%%rax), %%zmm17\n"
#define INSID_STORE3 \
  "vmovapd %%zmm16, 768(%%rax)\n vmovapd %%zmm17, 832(%%rax)\n vmovapd %%zmm16, 896(%%rax)\n"
#define INSID_ADD3                                                                         \
  "vaddpd %%zmm12, %%zmm18, %%zmm18\n vaddpd %%zmm12, %%zmm19, %%zmm19\n vaddpd %%zmm13, " \
  "%%zmm20, %%zmm20\n"
#define INSID_PROBE(body)                                                                        \
  asm volatile(                                                                                  \
      "vxorpd %%xmm12, %%xmm12, %%xmm12\n vxorpd %%xmm13, %%xmm13, %%xmm13\n"                    \
      "mov %[n], %%rcx\n lea %[buf], %%rax\n1:\n" body "dec %%rcx\n jnz 1b\n"                    \
      :                                                                                          \
      : [n] "r"(kProbeBlocks), [buf] "m"(probe_buffer)                                           \
      : "rcx", "rax", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8",    \
        "xmm9", "xmm10", "xmm11", "xmm12", "xmm13", "xmm16", "xmm17", "xmm18", "xmm19", "xmm20", \
        "memory")

enum class Probe { kFma, kFmaLoads, kFmaStores, kFmaLoadsStores, kKernelMix, kDiv, kFmaDiv, kSqrt };

__attribute__((target("avx512f"))) void BM_Pipe(benchmark::State& state, Probe probe) {
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx512f")) {
    state.SkipWithError("this CPU lacks AVX-512");
    return;
  }
  double fma_per_block = 12.0, div_per_block = 0.0;
  for (auto _ : state) {
    switch (probe) {
      case Probe::kFma:
        INSID_PROBE(INSID_FMA12);
        break;
      case Probe::kFmaLoads:
        INSID_PROBE(INSID_FMA12_LOAD10);
        break;
      case Probe::kFmaStores:
        INSID_PROBE(INSID_FMA12 INSID_STORE3);
        break;
      case Probe::kFmaLoadsStores:
        INSID_PROBE(INSID_FMA12_LOAD10 INSID_STORE3);
        break;
      case Probe::kKernelMix:
        INSID_PROBE(INSID_FMA12_LOAD10 INSID_STORE3 INSID_ADD3);
        break;
      case Probe::kDiv:  // 4 independent divisions per block, no FMA
        fma_per_block = 0.0;
        div_per_block = 4.0;
        INSID_PROBE(
            "vdivpd %%zmm12, %%zmm13, %%zmm0\n vdivpd %%zmm12, %%zmm13, %%zmm1\n"
            "vdivpd %%zmm12, %%zmm13, %%zmm2\n vdivpd %%zmm12, %%zmm13, %%zmm3\n");
        break;
      case Probe::kSqrt:  // 4 independent square roots per block (the fast search fitness's limit)
        fma_per_block = 0.0;
        div_per_block = 4.0;
        // Of 2.0 (a root of 0 may take a shortcut), loaded once per block.
        for (int k = 64; k < 72; ++k) probe_buffer[k] = 2.0;
        INSID_PROBE(
            "vmovapd 512(%%rax), %%zmm17\n"
            "vsqrtpd %%zmm17, %%zmm0\n vsqrtpd %%zmm17, %%zmm1\n"
            "vsqrtpd %%zmm17, %%zmm2\n vsqrtpd %%zmm17, %%zmm3\n");
        break;
      case Probe::kFmaDiv:  // 36 FMAs and 1 independent division (the kernel: 10 per 312)
        fma_per_block = 36.0;
        div_per_block = 1.0;
        INSID_PROBE(INSID_FMA12 "vdivpd %%zmm12, %%zmm13, %%zmm16\n" INSID_FMA12 INSID_FMA12);
        break;
    }
  }
  const double blocks = static_cast<double>(kProbeBlocks);
  if (fma_per_block > 0.0)
    state.counters["fma_zmm_per_ns"] = benchmark::Counter(
        fma_per_block * blocks * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
  if (div_per_block > 0.0)
    state.counters["div_zmm_per_ns"] = benchmark::Counter(
        div_per_block * blocks * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}
// Per 12 FMAs: loads 10 (8 as FMA operands), stores 3, adds 3 (the kernel mix: 0.83 loads,
// 0.25 stores and 0.25 adds per FMA-pipe operation; scripts/kernel_limit.py prints the kernel's).
BENCHMARK_CAPTURE(BM_Pipe, fma, Probe::kFma)->UseRealTime();
BENCHMARK_CAPTURE(BM_Pipe, fma_load10, Probe::kFmaLoads)->UseRealTime();
BENCHMARK_CAPTURE(BM_Pipe, fma_store3, Probe::kFmaStores)->UseRealTime();
BENCHMARK_CAPTURE(BM_Pipe, fma_load10_store3, Probe::kFmaLoadsStores)->UseRealTime();
BENCHMARK_CAPTURE(BM_Pipe, kernel_mix, Probe::kKernelMix)->UseRealTime();
BENCHMARK_CAPTURE(BM_Pipe, div, Probe::kDiv)->UseRealTime();
// Square roots (div_zmm_per_ns counts them): 512-bit vsqrtpd throughput, which bounds the fast
// search fitness's loop (scripts/fast_fitness_limit.py).
BENCHMARK_CAPTURE(BM_Pipe, sqrt, Probe::kSqrt)->UseRealTime();
// Whether the divider overlaps the FMA pipes (results/perf/xeon16/README.md): a block of fma_div
// takes 1 / div_zmm_per_ns ns; with the probes above, 36 FMAs alone take 36 / fma and a division
// alone 1 / div ns, so an overlapped block takes the longer of the two, a serialized one the sum.
BENCHMARK_CAPTURE(BM_Pipe, fma_div, Probe::kFmaDiv)->UseRealTime();
#undef INSID_PROBE
#undef INSID_ADD3
#undef INSID_STORE3
#undef INSID_FMA12_LOAD10
#undef INSID_FMA12
#endif  // __x86_64__ && __GNUC__

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
