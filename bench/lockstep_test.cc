// Campaign runs in lock-step with the batched kernel: the same results as the scalar
// reference evaluator within 1e-9 relative on every run's best fitness, and bit-identical run
// files for 1 and 2 threads.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "bench/campaign.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "test_support/files.h"

namespace insid::campaign {
namespace {
namespace fs = std::filesystem;

const char* kConfig = R"({
  "name": "test-lockstep",
  "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 300, "grade": "nav",
                 "data_seed": 5}],
  "algorithms": [{"label": "GA", "name": "ga"}, {"label": "PSO", "name": "pso"},
                 {"label": "DVPIO", "name": "dvpio", "parameters": {"dist_threshold": 0.1}}],
  "seeds": 3,
  "max_iterations": 4
})";

fs::path run_campaign_into(const std::string& name, int threads, bool scalar) {
  const fs::path dir = test::fresh_dir("lockstep-" + name);
  RunOptions options;
  options.out_dir = dir.string();
  options.threads = threads;
  options.quiet = true;
  options.scalar_reference = scalar;
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(kConfig), "test");
  EXPECT_TRUE(run_campaign(config, options).complete);
  return dir;
}

TEST(Lockstep, BatchedCampaignEqualsScalarAndDoesNotDependOnThreads) {
  // GIVEN the same small campaign run with the batched kernel on 1 and 2 threads and with the
  // scalar reference evaluator
  const fs::path one = run_campaign_into("batched-1", 1, false);
  const fs::path two = run_campaign_into("batched-2", 2, false);
  const fs::path scalar = run_campaign_into("scalar", 2, true);
  for (const char* label : {"GA", "PSO", "DVPIO"})
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      nlohmann::json a = test::read_json(run_file(one.string(), "rich-short", label, seed));
      nlohmann::json b = test::read_json(run_file(two.string(), "rich-short", label, seed));
      const nlohmann::json c =
          test::read_json(run_file(scalar.string(), "rich-short", label, seed));
      // THEN the thread count changes nothing but wall times
      a["result"].erase("wall_s");
      if (a.contains("uncertainty")) a["uncertainty"].erase("wall_s");  // timing
      b["result"].erase("wall_s");
      if (b.contains("uncertainty")) b["uncertainty"].erase("wall_s");  // timing
      EXPECT_EQ(a, b) << label << " seed " << seed;
      // AND the best fitness equals the scalar evaluator's within 1e-9 relative
      const double fb = a["result"]["fitness"].get<double>();
      const double fs = c["result"]["fitness"].get<double>();
      EXPECT_LE(std::abs(fb - fs), 1e-9 * std::abs(fs)) << label << " seed " << seed;
      EXPECT_EQ(a["result"]["evaluations"], c["result"]["evaluations"]);
    }
  fs::remove_all(one);
  fs::remove_all(two);
  fs::remove_all(scalar);
}

TEST(Lockstep, LeastSquaresRunsScoredTogetherEqualRunsDoneAlone) {
  // GIVEN a campaign of Levenberg-Marquardt runs (residual vectors) and BOBYQA runs, done once
  // in one wave (all LM residual batches in one evaluate_residual_batch call per round) and
  // once one run per invocation (--max-new-runs 1: each run alone in its wave)
  const char* config_text = R"({
    "name": "test-lockstep-lsq",
    "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 300, "grade": "nav",
                   "data_seed": 5}],
    "algorithms": [{"label": "LM", "name": "lm"}, {"label": "BOBYQA", "name": "bobyqa"}],
    "seeds": 3,
    "max_iterations": 0,
    "max_evaluations": 60
  })";
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(config_text), "test");
  auto dir_for = [](const std::string& name) { return test::fresh_dir("lockstep-" + name); };
  const fs::path together = dir_for("lsq-together");
  const fs::path alone = dir_for("lsq-alone");
  RunOptions options;
  options.threads = 2;
  options.quiet = true;
  options.out_dir = together.string();
  ASSERT_TRUE(run_campaign(config, options).complete);
  options.out_dir = alone.string();
  options.max_new_runs = 1;
  int invocations = 0;
  while (!run_campaign(config, options).complete) ASSERT_LT(++invocations, 10);
  EXPECT_EQ(invocations, 5);  // six runs, one per invocation
  // THEN every run file is the same but for the wall time
  for (const char* label : {"LM", "BOBYQA"})
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      nlohmann::json a = test::read_json(run_file(together.string(), "rich-short", label, seed));
      nlohmann::json b = test::read_json(run_file(alone.string(), "rich-short", label, seed));
      a["result"].erase("wall_s");
      if (a.contains("uncertainty")) a["uncertainty"].erase("wall_s");  // timing
      b["result"].erase("wall_s");
      if (b.contains("uncertainty")) b["uncertainty"].erase("wall_s");  // timing
      EXPECT_EQ(a, b) << label << " seed " << seed;
      EXPECT_EQ(a["result"]["evaluations"], 60) << label << " seed " << seed;
    }
  fs::remove_all(together);
  fs::remove_all(alone);
}

// The runner on every run of kConfig into a fresh directory, recording its waves.
struct Waves {
  std::vector<std::size_t> runs, candidates, targets;
  std::vector<RoundRecord> rounds;
  std::size_t evaluations = 0;  // of every run file
};
Waves run_runner_into(
    const fs::path& dir, double max_wave_s,
    const std::function<bool(const std::string&, std::uint64_t)>& keep = nullptr) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(kConfig), "test");
  std::vector<RunSpec> runs;
  std::vector<std::size_t> ids;
  for (std::size_t a = 0; a < config.algorithms.size(); ++a)
    for (std::uint64_t seed : config.seeds) {
      if (keep && !keep(config.algorithms[a].label, seed)) continue;
      ids.push_back(runs.size());
      runs.push_back(
          {0, a, seed, run_file(dir.string(), "rich-short", config.algorithms[a].label, seed)});
    }
  Waves waves;
  RunnerSettings settings;
  settings.out_dir = dir.string();
  settings.threads = 1;
  settings.max_wave_s = max_wave_s;
  settings.wave_finished = [&](std::size_t n, std::size_t candidates, std::size_t target, double) {
    waves.runs.push_back(n);
    waves.candidates.push_back(candidates);
    waves.targets.push_back(target);
  };
  settings.round_finished = [&](const RoundRecord& r) { waves.rounds.push_back(r); };
  LockstepRunner runner(config, settings, runs, 0, static_cast<int>(runs.size()));
  runner.run(ids, std::numeric_limits<std::size_t>::max(), OptimumSource::kCompute);
  EXPECT_EQ(runner.first_error(), "");
  EXPECT_EQ(runner.new_runs(), static_cast<int>(runs.size()));
  for (const RunSpec& run : runs)
    waves.evaluations += test::read_json(run.path)["result"]["evaluations"].get<std::size_t>();
  return waves;
}

TEST(Lockstep, WavesOfBoundedWallTimeKeepEveryResultAndTheOptimum) {
  // GIVEN the nine runs of kConfig done by the runner with no wave bound (one wave), with a
  // bound no wave can meet, and with a bound every wave meets
  const fs::path one_wave = test::fresh_dir("lockstep-one-wave");
  const fs::path tight = test::fresh_dir("lockstep-tight");
  const fs::path loose = test::fresh_dir("lockstep-loose");
  const Waves unbounded = run_runner_into(one_wave, 0.0);
  const Waves smallest = run_runner_into(tight, 1e-9);
  const Waves measured = run_runner_into(loose, 1e9);
  const std::size_t floor = wave_target(1, 0);  // 48 candidates per round on one thread

  // THEN without a bound every run is in one wave
  EXPECT_EQ(unbounded.runs, std::vector<std::size_t>{9});
  // AND with the tight bound every wave is the smallest that keeps the kernel busy, filled from
  // below: its first round holds at most `floor` candidates (whole two-vector groups), and the
  // next run (of at most 20 candidates) would not have fitted; the nine runs (120 candidates)
  // make three waves of 40
  ASSERT_GT(smallest.runs.size(), 2u);
  for (std::size_t w = 0; w < smallest.runs.size(); ++w) {
    EXPECT_EQ(smallest.targets[w], floor) << "wave " << w;
    EXPECT_LE(smallest.candidates[w], floor) << "wave " << w;
    if (w + 1 < smallest.runs.size()) {
      EXPECT_GT(smallest.candidates[w] + 20, floor) << "wave " << w;
    }
  }
  EXPECT_EQ(smallest.candidates, (std::vector<std::size_t>{40, 40, 40}));
  // AND the round records name each wave in turn with its runs, start with the wave's first
  // batch and add up to the evaluations of the run files
  ASSERT_FALSE(smallest.rounds.empty());
  std::size_t wave = 0, scored = 0;
  for (std::size_t k = 0; k < smallest.rounds.size(); ++k) {
    const RoundRecord& r = smallest.rounds[k];
    if (k > 0 && r.wave != wave) {
      EXPECT_EQ(r.wave, wave + 1) << "round " << k;
      wave = r.wave;
    }
    ASSERT_LT(r.wave, smallest.runs.size()) << "round " << k;
    EXPECT_EQ(r.wave_runs, smallest.runs[r.wave]) << "round " << k;
    if (k == 0 || smallest.rounds[k - 1].wave != r.wave) {
      EXPECT_EQ(r.candidates, smallest.candidates[r.wave]) << "round " << k;
    }
    EXPECT_LE(r.scoring_s, r.round_s) << "round " << k;
    scored += r.candidates;
  }
  EXPECT_EQ(wave + 1, smallest.runs.size());
  EXPECT_EQ(scored, smallest.evaluations);
  // AND with the loose bound the first wave, of unknown speed, is the smallest, and the next
  // takes every other run (its measured speed fits them all into the bound)
  ASSERT_EQ(measured.runs.size(), 2u);
  EXPECT_EQ(measured.targets[0], floor);
  EXPECT_EQ(measured.runs[0] + measured.runs[1], 9u);
  EXPECT_GT(measured.targets[1], 1000000u);

  // AND every run file and the optimum (found alongside the first wave) are the same
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(kConfig), "test");
  for (const fs::path& dir : {tight, loose}) {
    EXPECT_EQ(test::read_json(optimum_file(dir.string(), "rich-short")),
              test::read_json(optimum_file(one_wave.string(), "rich-short")));
    for (const AlgorithmSpec& algo : config.algorithms)
      for (std::uint64_t seed : config.seeds) {
        nlohmann::json a = test::read_json(run_file(dir.string(), "rich-short", algo.label, seed));
        nlohmann::json b =
            test::read_json(run_file(one_wave.string(), "rich-short", algo.label, seed));
        a["result"].erase("wall_s");
        if (a.contains("uncertainty")) a["uncertainty"].erase("wall_s");  // timing
        b["result"].erase("wall_s");
        if (b.contains("uncertainty")) b["uncertainty"].erase("wall_s");  // timing
        EXPECT_EQ(a, b) << dir << " " << algo.label << " seed " << seed;
      }
  }
  // AND the optimum found alongside the runs is the one found on its own before any run
  const std::shared_ptr<const Dataset> data = scenario_dataset(config.scenarios[0]);
  opt::EvaluatorOptions two_threads;
  two_threads.parallelism = opt::Parallelism::kOpenMP;
  two_threads.num_threads = 2;
  const InsIdentificationProblem problem(
      std::make_shared<const NavigationProblem>(data, NavigationOptions{config.alignment}),
      ParameterMapping(estimated_parameters(config)), FitnessKind::kEq15, two_threads,
      FitnessEvaluator::kBatched);
  nlohmann::json alone = find_reference_optimum(problem).to_json(problem.mapping());
  alone["scenario"] = "rich-short";
  EXPECT_EQ(test::read_json(optimum_file(one_wave.string(), "rich-short")), alone);
  for (const fs::path& dir : {one_wave, tight, loose}) fs::remove_all(dir);
}

TEST(Lockstep, ASmallTailOfRunsJoinsTheLastWave) {
  // GIVEN five runs of 10 candidates (PSO seeds 1-3, DVPIO seeds 1-2) under the tight bound, whose
  // waves hold at most 48 candidates a round on one thread
  const fs::path dir = test::fresh_dir("lockstep-tail");
  const Waves waves = run_runner_into(dir, 1e-9, [](const std::string& label, std::uint64_t seed) {
    return label == "PSO" || (label == "DVPIO" && seed <= 2);
  });
  // THEN the fifth run, which does not fit (50 > 48) and would be a wave of its own on one
  // thread's worth of candidates, joins the first wave
  EXPECT_EQ(waves.runs, std::vector<std::size_t>{5});
  EXPECT_EQ(waves.candidates, std::vector<std::size_t>{50});
  fs::remove_all(dir);
}

TEST(Lockstep, LeastSquaresRunsJoinAWaveWithinItsMemoryBound) {
  // GIVEN three Levenberg-Marquardt runs, done once under the default memory bound (a quarter
  // of the machine's memory) and once under a bound that holds less than one run
  const char* config_text = R"({
    "name": "test-lockstep-lsq-memory",
    "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 200, "grade": "nav",
                   "data_seed": 5}],
    "algorithms": [{"label": "LM", "name": "lm"}],
    "seeds": 3,
    "max_iterations": 0,
    "max_evaluations": 30
  })";
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(config_text), "test");
  auto run_under = [&](const std::string& name, std::size_t bound) {
    const fs::path dir = test::fresh_dir("lockstep-lsq-memory-" + name);
    fs::create_directories(dir);
    std::vector<RunSpec> runs;
    std::vector<std::size_t> ids;
    for (std::uint64_t seed : config.seeds) {
      ids.push_back(runs.size());
      runs.push_back({0, 0, seed, run_file(dir.string(), "rich-short", "LM", seed)});
    }
    RunnerSettings settings;
    settings.out_dir = dir.string();
    settings.threads = 2;
    settings.max_wave_residual_bytes = bound;
    std::vector<std::size_t> wave_runs;
    settings.wave_finished = [&](std::size_t n, std::size_t, std::size_t, double) {
      wave_runs.push_back(n);
    };
    LockstepRunner runner(config, settings, runs, 0, static_cast<int>(runs.size()));
    runner.run(ids, std::numeric_limits<std::size_t>::max(), OptimumSource::kCompute);
    EXPECT_EQ(runner.first_error(), "");
    return std::make_pair(dir, wave_runs);
  };
  const auto [together, together_waves] = run_under("default", 0);
  const auto [apart, apart_waves] = run_under("tight", 1);
  // THEN the default bound takes the three into one wave, the tight one makes a wave of each
  EXPECT_EQ(together_waves, std::vector<std::size_t>{3});
  EXPECT_EQ(apart_waves, (std::vector<std::size_t>{1, 1, 1}));
  // AND every run file is the same but for the wall times
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    nlohmann::json a = test::read_json(run_file(together.string(), "rich-short", "LM", seed));
    nlohmann::json b = test::read_json(run_file(apart.string(), "rich-short", "LM", seed));
    for (nlohmann::json* j : {&a, &b}) {
      (*j)["result"].erase("wall_s");
      if (j->contains("uncertainty")) (*j)["uncertainty"].erase("wall_s");  // timing
    }
    EXPECT_EQ(a, b) << "seed " << seed;
  }
  // AND the estimate of what one run holds covers the run measured on the 2.4 h paper flight
  // (388 MB more than a Nelder-Mead run; d = 4, 860000 GNSS epochs of two residuals)
  EXPECT_GE(least_squares_run_bytes(4, 2 * 860000), std::size_t{388} << 20);
  fs::remove_all(together);
  fs::remove_all(apart);
}

}  // namespace
}  // namespace insid::campaign
