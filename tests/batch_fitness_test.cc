// The batched kernel against the scalar reference (NavigationProblem::fitness / residuals) on
// short simulated flights of the paper, rich and straight scenarios, for random candidates of the
// general error model, every batch size 1..33 and 1 or 2 threads; and bit-for-bit invariance of
// a candidate's result under any grouping, position in the batch and thread count. Every
// instruction-set path the program holds and this CPU runs (kernel/cpu_path.h) is tested.
#include "kernel/batch_fitness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "kernel/cpu_path.h"
#include "scenarios/scenario.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

constexpr double kTolerance = 1e-9;  // relative, batched vs scalar

std::shared_ptr<const NavigationProblem> scenario_problem(
    const std::string& preset, AlignmentMode mode = AlignmentMode::kPerCandidate,
    double window_s = 0.0) {
  static std::map<std::string, std::shared_ptr<const Dataset>> datasets;
  auto& ds = datasets[preset];
  if (!ds && preset == "rich-jittered") {
    // insid-dataset/2 timing: the rich flight synthesised at 1 kHz, rows summed into steps of
    // 7-13 ms (10 ms +-30 %): the per-step two-sample weights and intervals in both paths.
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario("rich");
    cfg.flight_s = 600.0;
    cfg.align_s = 60.0;
    cfg.imu_rate_hz = 1000.0;
    cfg.substeps = 1;
    const Dataset fine = scenarios::simulate(cfg);
    Dataset jittered = test::jittered_rows(fine, 7, 13, 5, 100.0);
    ds = std::make_shared<const Dataset>(std::move(jittered));
  }
  if (!ds && preset == "rich-motors") {
    // A motor schedule: on 20 s into the navigation, off 100 s before its end, each edge inside
    // an IMU step (the steps that hold an edge carry a fractional motor part).
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario("rich");
    cfg.flight_s = 600.0;
    cfg.motors.on_s = {{cfg.align_s + 20.0037, cfg.align_s + 500.0051}};
    ds = std::make_shared<const Dataset>(scenarios::simulate(cfg));
  }
  if (!ds) {
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario(preset);
    cfg.flight_s = 600.0;
    ds = std::make_shared<const Dataset>(scenarios::simulate(cfg));
  }
  NavigationOptions options;
  options.alignment = mode;
  options.window_s = window_s;
  return std::make_shared<const NavigationProblem>(ds, options);
}

// Random candidates in the paper's box, every few of them with the other catalogue effects:
// bias drift, scale factors, misalignments, lever arm, GNSS latency (both signs).
std::vector<SensorErrors> random_candidates(int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  std::vector<SensorErrors> out;
  for (int i = 0; i < n; ++i) {
    SensorErrors c;
    c.accel.bias.x() = u(rng) * kSigmaAccelMps2;
    c.accel.bias.y() = u(rng) * kSigmaAccelMps2;
    c.gyro.bias.x() = u(rng) * kSigmaGyroRadS;
    c.gyro.bias.y() = u(rng) * kSigmaGyroRadS;
    const int kind = i % 6;
    if (kind == 1 || kind == 5) {
      c.gyro.bias.z() = u(rng) * kSigmaGyroRadS;
      c.accel.bias.z() = u(rng) * kSigmaAccelMps2;
      for (int j = 0; j < 3; ++j) {
        c.gyro.bias_drift[j] = u(rng) * kSigmaGyroRadS / 3600.0;
        c.accel.bias_drift[j] = u(rng) * kSigmaAccelMps2 / 3600.0;
      }
    }
    if (kind == 2 || kind == 5) {
      for (int j = 0; j < 3; ++j) {
        c.gyro.scale[j] = u(rng) * 1e-4;
        c.accel.scale[j] = u(rng) * 1e-4;
        for (int k = 0; k < 3; ++k)
          if (j != k) {
            c.gyro.misalign(j, k) = u(rng) * 1e-4;
            c.accel.misalign(j, k) = u(rng) * 1e-4;
          }
      }
    }
    if (kind == 3 || kind == 5)
      for (int j = 0; j < 3; ++j) c.lever_arm_b_m[j] = u(rng) * 0.1;
    if (kind == 4 || kind == 5) c.gnss_latency_s = u(rng) * 0.01;  // up to 4 IMU steps, +-
    if (kind == 0 || kind == 5)  // nothing without a motor schedule; in the general path with one
      for (int j = 0; j < 3; ++j) {
        c.gyro.motor_offset[j] = u(rng) * kSigmaGyroRadS;
        c.accel.motor_offset[j] = u(rng) * kSigmaAccelMps2;
      }
    out.push_back(c);
  }
  return out;
}

double relative_difference(double a, double b) {
  return std::abs(a - b) / std::max(std::abs(b), 1e-300);
}

// ----- instruction-set paths ---------------------------------------------------------------------

// The x86-64 levels this CPU has by its /proc/cpuinfo flags, independently of insid's own check
// (scripts/test_cpu_paths.py reads them the same way). LZCNT ("abm") is left out: some
// hypervisors hide the flag while the CPUID bit is set.
std::set<std::string> cpuinfo_paths() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  std::set<std::string> flags;
  while (std::getline(in, line))
    if (line.rfind("flags", 0) == 0) {
      std::istringstream words(line.substr(line.find(':') + 1));
      for (std::string w; words >> w;) flags.insert(w);
      break;
    }
  auto has = [&](std::initializer_list<const char*> names) {
    for (const char* n : names)
      if (!flags.contains(n)) return false;
    return true;
  };
  std::set<std::string> out = {"baseline"};
  if (has({"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "movbe", "xsave"})) {
    out.insert("avx2");
    if (has({"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"})) out.insert("avx512");
  }
  return out;
}

// The paths the program holds that this CPU runs (KernelPaths.* checks that none is missing).
std::vector<std::string> runnable_paths() {
  std::vector<std::string> out;
  for (const std::string& p : compiled_cpu_paths())
    if (cpu_runs_path(p)) out.push_back(p);
  return out;
}

TEST(KernelPaths, TheProgramHoldsEveryPathAndRunsEachOneThisCpuHas) {
  const std::vector<std::string> compiled = compiled_cpu_paths();
#if defined(INSID_TEST_CPU_DISPATCH)
  // GIVEN the CPU-dispatching build: THEN it holds all three paths, fastest first
  ASSERT_EQ(compiled, (std::vector<std::string>{"avx512", "avx2", "baseline"}));
  // AND it runs exactly the ones this CPU's flags allow (no path skipped on a CPU that has it)
  const std::set<std::string> cpu = cpuinfo_paths();
  for (const std::string& p : compiled)
    EXPECT_EQ(cpu_runs_path(p), cpu.contains(p)) << "path " << p;
  // AND the program uses the fastest of them (unless INSID_CPU says otherwise)
  if (std::getenv("INSID_CPU") == nullptr) {
    EXPECT_EQ(cpu_path_description().rfind(runnable_paths().front() + " ", 0), 0u)
        << cpu_path_description();
  }
#else
  ASSERT_EQ(compiled, std::vector<std::string>{"native"});
  EXPECT_TRUE(cpu_runs_path("native"));
#endif
  // A path the program does not hold is refused by name.
  EXPECT_THROW(cpu_path_named("avx1024"), std::invalid_argument);
}

std::vector<double> batched(const BatchFitness& kernel, std::span<const SensorErrors> c,
                            int threads, FitnessKind kind = FitnessKind::kEq15,
                            const std::string& path = "") {
  return kernel.fitness(c, kind, threads, path);
}

// Scenario x instruction-set path (those the program holds: KernelPaths.* checks the list).
class BatchVsScalar : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {
 protected:
  void SetUp() override {
    const std::string& path = std::get<1>(GetParam());
    if (!cpu_runs_path(path))
      GTEST_SKIP() << "this CPU lacks the kernel path " << path
                   << " (KernelPaths.* checks that against /proc/cpuinfo)";
  }
  const std::string& scenario() const { return std::get<0>(GetParam()); }
  const std::string& path() const { return std::get<1>(GetParam()); }
};

TEST_P(BatchVsScalar, EveryBatchSizeAndThreadCountMatchesTheReference) {
  // GIVEN a short flight of the scenario and 33 random candidates of the general model
  const auto nav = scenario_problem(scenario());
  const BatchFitness kernel(nav);
  ASSERT_TRUE(kernel.supported()) << kernel.unsupported_reason();
  const std::vector<SensorErrors> pool = random_candidates(33, 7);
  std::vector<double> reference;
  for (const SensorErrors& c : pool) reference.push_back(nav->fitness(c));

  // WHEN every prefix of 1..33 candidates is scored with 1 and 2 threads
  // THEN each equals the scalar reference within 1e-9 relative and is bit-identical to the
  // same candidate's result in every other batch.
  std::vector<double> first;
  double worst = 0.0;
  for (int K = 1; K <= 33; ++K)
    for (int threads : {1, 2}) {
      const std::vector<double> f = batched(kernel, std::span<const SensorErrors>(pool).first(K),
                                            threads, FitnessKind::kEq15, path());
      if (first.empty()) first.assign(33, std::nan(""));
      for (int i = 0; i < K; ++i) {
        const double rel = relative_difference(f[i], reference[i]);
        worst = std::max(worst, rel);
        EXPECT_LE(rel, kTolerance) << "K=" << K << " threads=" << threads << " candidate " << i
                                   << ": " << f[i] << " vs " << reference[i];
        if (std::isnan(first[i])) first[i] = f[i];
        EXPECT_EQ(f[i], first[i]) << "K=" << K << " threads=" << threads << " candidate " << i;
      }
    }
  std::cout << scenario() << ", path " << path() << ": worst relative difference " << worst << "\n";
}

TEST_P(BatchVsScalar, ResidualsAndSumOfSquaresMatchTheReference) {
  const auto nav = scenario_problem(scenario());
  const BatchFitness kernel(nav);
  const std::vector<SensorErrors> pool = random_candidates(12, 11);
  std::vector<std::vector<double>> r(pool.size());
  std::vector<double> f(pool.size());
  BatchFitness::Request request;
  request.candidates = pool;
  request.fitness = f;
  request.kind = FitnessKind::kSumSquares;
  request.residuals = r;
  request.cpu_path = path();
  kernel.evaluate(request);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    std::vector<double> ref;
    nav->residuals(pool[i], ref);
    ASSERT_EQ(r[i].size(), ref.size());
    double scale = 0.0, diff = 0.0;
    for (std::size_t j = 0; j < ref.size(); ++j) {
      scale = std::max(scale, std::abs(ref[j]));
      diff = std::max(diff, std::abs(r[i][j] - ref[j]));
    }
    EXPECT_LE(diff, 1e-9 * scale) << "candidate " << i;
    EXPECT_LE(relative_difference(f[i], nav->fitness(pool[i], FitnessKind::kSumSquares)),
              kTolerance)
        << "candidate " << i;
  }
  // Two threads size the vectors themselves (stale contents and sizes are replaced) and give
  // the same bits.
  std::vector<std::vector<double>> r2(pool.size(), std::vector<double>(3, 7.0));
  request.residuals = r2;
  request.threads = 2;
  kernel.evaluate(request);
  for (std::size_t i = 0; i < pool.size(); ++i) EXPECT_EQ(r2[i], r[i]) << "candidate " << i;
}

INSTANTIATE_TEST_SUITE_P(Scenarios, BatchVsScalar,
                         ::testing::Combine(::testing::Values("paper", "rich", "straight",
                                                              "rich-jittered", "rich-motors"),
                                            ::testing::ValuesIn(compiled_cpu_paths())),
                         [](const auto& param_info) {
                           std::string name =
                               std::get<0>(param_info.param) + "_" + std::get<1>(param_info.param);
                           std::erase(name, '-');
                           return name;
                         });

TEST(BatchFitness, FixedAlignmentMatchesTheReference) {
  const auto nav = scenario_problem("rich", AlignmentMode::kFixed);
  const BatchFitness kernel(nav);
  const std::vector<SensorErrors> pool = random_candidates(10, 3);
  const std::vector<double> f = batched(kernel, pool, 2);
  for (std::size_t i = 0; i < pool.size(); ++i)
    EXPECT_LE(relative_difference(f[i], nav->fitness(pool[i])), kTolerance) << i;
}

TEST(BatchFitness, ResultsDoNotDependOnGroupingOrderOrThreads) {
  // GIVEN 40 candidates of all kinds (mixed latencies make per-lane epoch schedules)
  const auto nav = scenario_problem("rich");
  const BatchFitness kernel(nav);
  const std::vector<SensorErrors> pool = random_candidates(40, 5);
  for (const std::string& path : runnable_paths()) {
    SCOPED_TRACE("kernel path " + path);
    const std::vector<double> base = batched(kernel, pool, 1, FitnessKind::kEq15, path);
    // WHEN they are scored in other groupings, in reverse order, or only the latency-free ones
    for (const std::vector<int>& groups :
         {std::vector<int>{1, 1, 1, 1, 1}, {2, 2, 1}, {1, 2, 2}, {2, 1, 2}}) {
      std::vector<double> f(pool.size());
      BatchFitness::Request request;
      request.candidates = pool;
      request.fitness = f;
      request.threads = 2;
      request.cpu_path = path;
      kernel.evaluate_grouped(request, groups);
      for (std::size_t i = 0; i < pool.size(); ++i) EXPECT_EQ(f[i], base[i]) << i;
    }
    std::vector<SensorErrors> reversed(pool.rbegin(), pool.rend());
    const std::vector<double> fr = batched(kernel, reversed, 2, FitnessKind::kEq15, path);
    for (std::size_t i = 0; i < pool.size(); ++i) EXPECT_EQ(fr[pool.size() - 1 - i], base[i]) << i;
    std::vector<SensorErrors> no_latency;
    std::vector<double> expected;
    for (std::size_t i = 0; i < pool.size(); ++i)
      if (pool[i].gnss_latency_s == 0.0) {
        no_latency.push_back(pool[i]);
        expected.push_back(base[i]);
      }
    const std::vector<double> fn = batched(kernel, no_latency, 1, FitnessKind::kEq15, path);
    // THEN every candidate's fitness is bit-identical
    for (std::size_t i = 0; i < fn.size(); ++i) EXPECT_EQ(fn[i], expected[i]) << i;
  }
}

TEST(BatchFitness, GroupPlanCoversTheVectors) {
  for (int threads = 1; threads <= 4; ++threads)
    for (int nv = 1; nv <= 40; ++nv) {
      const std::vector<int> g = BatchFitness::plan_groups(nv, threads);
      int total = 0;
      for (int s : g) {
        EXPECT_GE(s, 1);
        EXPECT_LE(s, BatchFitness::planned_chains());
        total += s;
      }
      EXPECT_EQ(total, nv);
      if (nv >= threads) {
        EXPECT_GE(static_cast<int>(g.size()), threads);
      }
    }
}

TEST(BatchFitness, AFailingCandidateIsReportedAndTheOthersScored) {
  const auto nav = scenario_problem("straight");
  const BatchFitness kernel(nav);
  std::vector<SensorErrors> pool = random_candidates(9, 2);
  pool[4].accel.scale = Eigen::Vector3d::Constant(-1.0);  // singular: alignment throws
  std::vector<double> f(pool.size());
  std::vector<std::exception_ptr> errors(pool.size());
  BatchFitness::Request request;
  request.candidates = pool;
  request.fitness = f;
  request.errors = errors;
  kernel.evaluate(request);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    if (i == 4) {
      EXPECT_TRUE(errors[i]);
      EXPECT_TRUE(std::isnan(f[i]));
    } else {
      EXPECT_FALSE(errors[i]) << i;
      EXPECT_LE(relative_difference(f[i], nav->fitness(pool[i])), kTolerance) << i;
    }
  }
  request.errors = {};
  EXPECT_THROW(kernel.evaluate(request), std::invalid_argument);

  // With residuals, on two threads: the failed candidate's vector is all zeros, at full size.
  std::vector<std::vector<double>> r(pool.size(), std::vector<double>(5, 1.0));
  request.residuals = r;
  request.errors = errors;
  request.threads = 2;
  kernel.evaluate(request);
  std::vector<double> ref;
  nav->residuals(pool[0], ref);
  ASSERT_EQ(r[4].size(), ref.size());
  EXPECT_EQ(std::count(r[4].begin(), r[4].end(), 0.0), static_cast<std::ptrdiff_t>(ref.size()));
  EXPECT_EQ(r[0].size(), ref.size());
  EXPECT_NE(r[0], std::vector<double>(ref.size(), 0.0));
}

// ----- windowed fitness --------------------------------------------------------------------------

// The random candidates plus a few far outside the paper's box (MEMS-like: 0.5 deg/s gyro,
// 20 mg accelerometer biases), whose one-run navigation drifts by kilometres: their restarts
// jump far, so a restart that the kernel does differently from the reference shows.
std::vector<SensorErrors> windowed_candidates(int n, unsigned seed) {
  std::vector<SensorErrors> out = random_candidates(n, seed);
  std::mt19937_64 rng(seed + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < out.size(); i += 4) {
    out[i].gyro.bias.x() = u(rng) * 0.5 * kDegToRad;
    out[i].gyro.bias.y() = u(rng) * 0.5 * kDegToRad;
    out[i].accel.bias.x() = u(rng) * 0.2;
    out[i].accel.bias.y() = u(rng) * 0.2;
  }
  return out;
}

TEST(BatchFitnessWindowed, KernelMatchesTheReferenceForSeveralWindowsAndBatchSizes) {
  // GIVEN the rich flight (turns, 10 Hz GNSS) and windows from one GNSS period to longer than
  // the flight; candidates of every kind (lever arm, latency of both signs, distortion) and a
  // few MEMS-sized ones
  const std::vector<SensorErrors> pool = windowed_candidates(33, 17);
  for (double window_s : {0.1, 7.3, 60.0, 1e4}) {
    const auto nav = scenario_problem("rich", AlignmentMode::kPerCandidate, window_s);
    if (window_s < 1e3) {
      ASSERT_GE(nav->window_restarts().size(), 600.0 / window_s - 2) << window_s;
    } else {
      ASSERT_TRUE(nav->window_restarts().empty());
    }
    const BatchFitness kernel(nav);
    ASSERT_TRUE(kernel.supported()) << kernel.unsupported_reason();
    std::vector<double> reference;
    for (const SensorErrors& c : pool) reference.push_back(nav->fitness(c));
    // WHEN batches of K = 1, 8, 13, 33 are scored on 1 and 2 threads
    // THEN every candidate matches the scalar reference within the kernel's tolerance and is
    // bit-identical across batch sizes and threads
    // (every path this CPU runs)
    for (const std::string& path : runnable_paths()) {
      double worst = 0.0;
      for (int K : {1, 8, 13, 33})
        for (int threads : {1, 2}) {
          const std::vector<double> f =
              batched(kernel, std::span<const SensorErrors>(pool).first(K), threads,
                      FitnessKind::kEq15, path);
          for (int i = 0; i < K; ++i) {
            const double rel = relative_difference(f[i], reference[i]);
            worst = std::max(worst, rel);
            EXPECT_LE(rel, kTolerance)
                << "path " << path << " W=" << window_s << " K=" << K << " threads=" << threads
                << " candidate " << i << ": " << f[i] << " vs " << reference[i];
            if (K == 33 && threads == 2) {
              const std::vector<double> one =
                  batched(kernel, std::span<const SensorErrors>(pool).subspan(i, 1), 1,
                          FitnessKind::kEq15, path);
              EXPECT_EQ(f[i], one[0]) << "path " << path << " W=" << window_s << " candidate " << i;
            }
          }
        }
      std::cout << "rich, window_s = " << window_s << ", path " << path << ": "
                << nav->num_windows() << " windows, worst relative difference " << worst << "\n";
    }
  }
}

TEST(BatchFitnessWindowed, ResidualsAndSumOfSquaresMatchTheReference) {
  const std::vector<SensorErrors> pool = windowed_candidates(12, 23);
  for (const char* preset : {"paper", "straight"}) {
    const auto nav = scenario_problem(preset, AlignmentMode::kPerCandidate, 20.0);
    ASSERT_GE(nav->window_restarts().size(), 25u);
    const BatchFitness kernel(nav);
    std::vector<std::vector<double>> r(pool.size());
    std::vector<double> f(pool.size());
    BatchFitness::Request request;
    request.candidates = pool;
    request.fitness = f;
    request.kind = FitnessKind::kSumSquares;
    request.residuals = r;
    kernel.evaluate(request);
    for (std::size_t i = 0; i < pool.size(); ++i) {
      std::vector<double> ref;
      nav->residuals(pool[i], ref);
      ASSERT_EQ(r[i].size(), ref.size());
      double scale = 0.0, diff = 0.0;
      for (std::size_t j = 0; j < ref.size(); ++j) {
        scale = std::max(scale, std::abs(ref[j]));
        diff = std::max(diff, std::abs(r[i][j] - ref[j]));
      }
      EXPECT_LE(diff, 1e-9 * scale) << preset << " candidate " << i;
      EXPECT_LE(relative_difference(f[i], nav->fitness(pool[i], FitnessKind::kSumSquares)),
                kTolerance)
          << preset << " candidate " << i;
    }
  }
}

TEST(BatchFitnessWindowed, NoRestartIsTheOneRunKernelBitForBit) {
  // W = 0 and W longer than the flight: the same kernel results, bit for bit.
  const std::vector<SensorErrors> pool = windowed_candidates(16, 29);
  const BatchFitness zero(scenario_problem("rich", AlignmentMode::kPerCandidate, 0.0));
  const BatchFitness longer(scenario_problem("rich", AlignmentMode::kPerCandidate, 5000.0));
  EXPECT_EQ(batched(zero, pool, 2), batched(longer, pool, 2));
  // and a window inside the flight changes them (the restarts are really done)
  const BatchFitness inside(scenario_problem("rich", AlignmentMode::kPerCandidate, 100.0));
  const std::vector<double> a = batched(zero, pool, 2), b = batched(inside, pool, 2);
  for (std::size_t i = 0; i < pool.size(); ++i) EXPECT_NE(a[i], b[i]) << i;
}

// ----- GNSS latency and lever arm under the windowed fitness -------------------------------------

// A noise-free racetrack flight (60 s legs: takeoff, a speed-up to 20 m/s, two 180 deg turns at
// 3 deg/s; 300 s after the 600 s alignment) with the paper's four, a GNSS latency of 0.2 s and a
// lever arm of (1.0, 0.5, 0) m, and the truth candidate.
std::shared_ptr<const Dataset> gnss_effects_flight() {
  static const std::shared_ptr<const Dataset> ds = [] {
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario("racetrack");
    cfg.flight_s = 300.0;
    for (auto& segment : cfg.repeat)
      if (segment["type"] == "straight") segment["duration_s"] = 60.0;
    cfg.noise = scenarios::noise_grade("none");
    cfg.injected.gnss_latency_s = 0.2;
    cfg.injected.lever_arm_b_m = Eigen::Vector3d(1.0, 0.5, 0.0);
    return std::make_shared<const Dataset>(scenarios::simulate(cfg));
  }();
  return ds;
}

TEST(BatchFitnessWindowed, TheFitnessIsLeastAtTheHiddenLatencyAndLeverArm) {
  // GIVEN the noise-free flight and the truth candidate
  const auto ds = gnss_effects_flight();
  SensorErrors truth = test::paper_errors();
  truth.gnss_latency_s = 0.2;
  truth.lever_arm_b_m = Eigen::Vector3d(1.0, 0.5, 0.0);
  // The truth moved along one GNSS-side effect by `step` (latency in s, lever arm in m).
  const auto moved = [&](int effect, double step) {
    SensorErrors c = truth;
    if (effect == 0) c.gnss_latency_s += step;
    if (effect > 0) c.lever_arm_b_m[effect - 1] += step;
    return c;
  };
  const char* names[] = {"gnss_latency", "lever_arm_x", "lever_arm_y"};
  const double steps[] = {0.02, 0.1, 0.1};  // 10 % of the latency, 0.1 m of the arms
  for (double window_s : {0.0, 10.0, 20.0}) {
    NavigationOptions options;
    options.window_s = window_s;
    const auto nav = std::make_shared<const NavigationProblem>(ds, options);
    const BatchFitness kernel(nav);
    ASSERT_TRUE(kernel.supported()) << kernel.unsupported_reason();
    // WHEN the truth and the truth moved by +-step along each effect are scored, all in one
    // batch (lanes of different latencies and lever arms), by the kernel and the reference
    std::vector<SensorErrors> pool = {truth};
    for (int effect = 0; effect < 3; ++effect)
      for (double sign : {-1.0, 1.0}) pool.push_back(moved(effect, sign * steps[effect]));
    for (FitnessKind kind : {FitnessKind::kEq15, FitnessKind::kSumSquares}) {
      const std::vector<double> f = batched(kernel, pool, 2, kind);
      std::vector<double> ref;
      for (const SensorErrors& c : pool) ref.push_back(nav->fitness(c, kind));
      // THEN both agree within the kernel's tolerance, and along every effect the truth scores
      // lower than a step to either side (the fitness is least within a step of the truth; a
      // window start that cancels the effects' signal puts the least far below it)
      // On noise-free data every fitness of this pool is a near-cancellation (Eq. 15 of 0.007-27
      // from velocities of 10-20 m/s, the sum of squares down to 1e-4): each is compared
      // relative to the surface's scale, the largest fitness of the pool of that kind. The
      // scalar reference is compiled for baseline x86-64 (no FMA) while the
      // kernel's AVX-512 and AVX2 paths fuse: they differ by rounding of 1e-11 absolute, which
      // is 1.1-1.3e-9 of the lever-arm candidates' own sums of squares (0.007-0.02) at W = 10
      // and 20 s (printed below relative to the scale).
      double scale = 0.0, worst = 0.0;
      for (double r : ref) scale = std::max(scale, std::abs(r));
      for (std::size_t i = 0; i < pool.size(); ++i) {
        worst = std::max(worst, std::abs(f[i] - ref[i]) / scale);
        EXPECT_LE(std::abs(f[i] - ref[i]) / scale, kTolerance)
            << "W=" << window_s << " candidate " << i << ": " << f[i] << " vs " << ref[i];
      }
      std::cout << "W = " << window_s << " s, "
                << (kind == FitnessKind::kEq15 ? "Eq. 15" : "sum of squares")
                << ": kernel vs reference, worst " << worst << " of the surface's scale " << scale
                << "\n";
      for (int effect = 0; effect < 3; ++effect)
        for (int side = 0; side < 2; ++side) {
          const std::size_t i =
              1 + 2 * static_cast<std::size_t>(effect) + static_cast<std::size_t>(side);
          EXPECT_LT(ref[0], ref[i]) << "W=" << window_s << " " << names[effect]
                                    << (side == 0 ? " -" : " +") << steps[effect];
          EXPECT_LT(f[0], f[i]) << "W=" << window_s << " kernel " << names[effect]
                                << (side == 0 ? " -" : " +") << steps[effect];
        }
      if (kind == FitnessKind::kEq15)
        std::cout << "W = " << window_s << " s: Eq. 15 at the truth " << ref[0]
                  << ", latency -+20 ms " << ref[1] << " " << ref[2] << ", lever_arm_x -+0.1 m "
                  << ref[3] << " " << ref[4] << ", lever_arm_y -+0.1 m " << ref[5] << " " << ref[6]
                  << "\n";
    }
  }
}

TEST(BatchFitnessWindowed, TheFitnessIsContinuousInTheLatencyAcrossWindowBoundaries) {
  // GIVEN the noise-free flight with 10 s windows (boundaries on GNSS epochs: at a latency of
  // 0.2 s the antenna time of an epoch falls on every boundary) and the truth with a 2 sigma
  // accelerometer bias error (the windows drift, so an epoch compared before or after a restart
  // differs by what its window built)
  NavigationOptions options;
  options.window_s = 10.0;
  const auto nav = std::make_shared<const NavigationProblem>(gnss_effects_flight(), options);
  const BatchFitness kernel(nav);
  SensorErrors c = test::paper_errors();
  c.accel.bias.x() += 2.0 * kSigmaAccelMps2;
  c.lever_arm_b_m = Eigen::Vector3d(1.0, 0.5, 0.0);
  // WHEN it is scored at latencies 0.2 s -+ 1e-7 s and -+ 1e-3 s
  std::vector<SensorErrors> pool;
  for (double d : {-1e-7, 1e-7, -1e-3, 1e-3}) {
    pool.push_back(c);
    pool.back().gnss_latency_s = 0.2 + d;
  }
  std::vector<double> ref;
  for (const SensorErrors& p : pool) ref.push_back(nav->fitness(p));
  const std::vector<double> f = batched(kernel, pool, 1);
  // THEN across 2e-7 s the fitness changes by less than 1e-3 of its change across 2e-3 s (it
  // is continuous: each window starts at the antenna time of its boundary, so no epoch moves to
  // another window as the latency passes a boundary), in the reference and the kernel
  std::cout << "fitness at 0.2 s -+1e-7: " << ref[0] << " " << ref[1] << ", -+1e-3: " << ref[2]
            << " " << ref[3] << "\n";
  EXPECT_LT(std::abs(ref[1] - ref[0]), 1e-3 * std::abs(ref[3] - ref[2]));
  EXPECT_LT(std::abs(f[1] - f[0]), 1e-3 * std::abs(f[3] - f[2]));
}

TEST(BatchFitnessWindowed, PerLaneRestartsMatchTheReferenceForLargeLatenciesAndLeverArms) {
  // GIVEN the noise-free flight, 10 s windows and 13 candidates that differ in latency (of both
  // signs, up to 0.3 s: thirty IMU steps) and lever arm (up to 2 m on every axis), some with
  // neither, and the IMU errors of the random pool
  NavigationOptions options;
  options.window_s = 10.0;
  const auto nav = std::make_shared<const NavigationProblem>(gnss_effects_flight(), options);
  ASSERT_GE(nav->window_restarts().size(), 25u);
  const BatchFitness kernel(nav);
  std::vector<SensorErrors> pool = random_candidates(13, 41);
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    if (i % 4 == 3) continue;
    if (i % 4 != 1) pool[i].gnss_latency_s = 0.3 * u(rng);
    if (i % 4 != 2)
      for (int j = 0; j < 3; ++j) pool[i].lever_arm_b_m[j] = 2.0 * u(rng);
  }
  for (const std::string& path : runnable_paths()) {
    SCOPED_TRACE("kernel path " + path);
    // WHEN they are scored in one batch with their residuals
    std::vector<std::vector<double>> r(pool.size());
    std::vector<double> f(pool.size());
    BatchFitness::Request request;
    request.candidates = pool;
    request.fitness = f;
    request.residuals = r;
    request.cpu_path = path;
    kernel.evaluate(request);
    // THEN every fitness and residual matches the reference's within the kernel's tolerance
    for (std::size_t i = 0; i < pool.size(); ++i) {
      std::vector<double> ref;
      nav->residuals(pool[i], ref);
      ASSERT_EQ(r[i].size(), ref.size());
      double scale = 0.0, diff = 0.0;
      for (std::size_t j = 0; j < ref.size(); ++j) {
        scale = std::max(scale, std::abs(ref[j]));
        diff = std::max(diff, std::abs(r[i][j] - ref[j]));
      }
      EXPECT_LE(diff, 1e-9 * scale) << "candidate " << i;
      EXPECT_LE(relative_difference(f[i], nav->fitness(pool[i])), kTolerance) << "candidate " << i;
    }
  }
}

}  // namespace
}  // namespace insid
