// External optimizers in campaigns: the reference Python client
// (scripts/external_random_search.py) gives the same runs as the same random search computed
// directly (numpy draws, scored by the campaign's own INS problem) for 1 and 2 threads; a
// crashing client fails its own runs with the documented error and the others are written.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <gtest/gtest.h>

#include "bench/campaign.h"
#include "identification/ins_problem.h"
#include "test_support/files.h"
#include "test_support/process.h"

namespace insid::campaign {
namespace {
namespace fs = std::filesystem;

nlohmann::json config_json(bool with_crash) {
  nlohmann::json algorithms = {
      {{"label", "RS-py"}, {"name", "external:" + test::kPython + " " + test::kExternalClient}},
      {{"label", "PSO"}, {"name", "pso"}}};
  if (with_crash)
    algorithms.push_back(
        {{"label", "crash"},
         {"name", "external:" + test::kPython + " " + test::kExternalTestClient + " crash"}});
  return {{"name", "test-external"},
          {"scenarios",
           {{{"name", "rich-short"},
             {"preset", "rich"},
             {"flight_s", 300},
             {"grade", "nav"},
             {"data_seed", 5}}}},
          {"algorithms", algorithms},
          {"seeds", 2},
          {"max_iterations", 0},
          {"max_evaluations", 25}};
}

// numpy's default_rng(seed): `count` uniform points in [-1, 1]^n drawn at once.
std::vector<Eigen::VectorXd> numpy_points(std::uint64_t seed, int n, int count) {
  const std::string script = "import json, numpy as np; p = np.random.default_rng(" +
                             std::to_string(seed) + ").uniform([-1.0] * " + std::to_string(n) +
                             ", [1.0] * " + std::to_string(n) + ", size=(" + std::to_string(count) +
                             ", " + std::to_string(n) + ")); print(json.dumps(p.tolist()))";
  const nlohmann::json j =
      nlohmann::json::parse(test::run_command(test::kPython + " -c '" + script + "'"));
  std::vector<Eigen::VectorXd> points;
  for (const auto& row : j) {
    Eigen::VectorXd x(n);
    for (int d = 0; d < n; ++d) x[d] = row[static_cast<std::size_t>(d)].get<double>();
    points.push_back(x);
  }
  return points;
}

// On the exact kernel (--fitness exact) the client's fitness is the problem's, point by point;
// with the fast search fitness (the default, issue 47) too the thread count changes nothing.
class ExternalCampaignFitness : public ::testing::TestWithParam<SearchFitnessKind> {};

TEST_P(ExternalCampaignFitness, PythonRandomSearchEqualsDirectComputationFor1And2Threads) {
  if (!test::python_with_numpy()) GTEST_SKIP() << test::kPython << " with numpy is not available";
  CampaignConfig config = parse_campaign(config_json(false), "test");
  config.search_fitness = GetParam();
  const bool exact = GetParam() == SearchFitnessKind::kExact;
  std::map<int, fs::path> dirs;
  for (const int threads : {1, 2}) {
    dirs[threads] =
        test::fresh_dir("threads-" + std::to_string(threads) + std::string(to_string(GetParam())));
    RunOptions options;
    options.out_dir = dirs[threads].string();
    options.threads = threads;
    options.quiet = true;
    ASSERT_TRUE(run_campaign(config, options).complete);
  }

  // The same random search computed directly: numpy's points scored by the campaign's problem.
  const auto dataset = scenario_dataset(config.scenarios[0]);
  const auto navigation =
      std::make_shared<const NavigationProblem>(dataset, NavigationOptions{config.alignment});
  const InsIdentificationProblem problem(navigation,
                                         ParameterMapping(estimated_parameters(config)));
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    const std::vector<Eigen::VectorXd> points = numpy_points(seed, problem.dimension(), 25);
    ASSERT_EQ(points.size(), 25u);
    std::vector<double> f(points.size());
    problem.evaluate_batch(points, f);
    std::vector<double> best_per_evaluation;
    double best = std::numeric_limits<double>::infinity();
    for (double fi : f) best_per_evaluation.push_back(best = std::min(best, fi));

    nlohmann::json one = test::read_json(run_file(dirs[1].string(), "rich-short", "RS-py", seed));
    nlohmann::json two = test::read_json(run_file(dirs[2].string(), "rich-short", "RS-py", seed));
    if (exact) {
      EXPECT_EQ(one["result"]["best_per_evaluation"].get<std::vector<double>>(),
                best_per_evaluation)
          << "seed " << seed;
    }
    // The reported fitness is the exact kernel's, with either search fitness.
    EXPECT_EQ(one["result"]["fitness"].get<double>(), best);
    EXPECT_EQ(one["result"]["evaluations"], 25);
    EXPECT_EQ(one["result"]["iterations"], 3);  // 10 + 10 + 5
    // Seed 1 records its batches (record_positions_seeds = 1): each point's own fitness, in order.
    if (seed == 1 && exact) {
      std::vector<double> told;
      for (const nlohmann::json& h : one["result"]["history"])
        for (const nlohmann::json& fi : h.at("positions_fitness")) told.push_back(fi.get<double>());
      EXPECT_EQ(told, f);
    }
    // The thread count changes nothing but wall times.
    one["result"].erase("wall_s");
    if (one.contains("uncertainty")) one["uncertainty"].erase("wall_s");  // timing
    two["result"].erase("wall_s");
    if (two.contains("uncertainty")) two["uncertainty"].erase("wall_s");  // timing
    EXPECT_EQ(one, two) << "seed " << seed;
  }
  for (const auto& [threads, dir] : dirs) fs::remove_all(dir);
}
INSTANTIATE_TEST_SUITE_P(BothFitnesses, ExternalCampaignFitness,
                         ::testing::Values(SearchFitnessKind::kExact, SearchFitnessKind::kFast),
                         [](const auto& param_info) {
                           return std::string(to_string(param_info.param));
                         });

TEST(ExternalCampaign, CrashingClientFailsOnlyItsOwnRuns) {
  if (!test::python_with_numpy()) GTEST_SKIP() << test::kPython << " with numpy is not available";
  const CampaignConfig config = parse_campaign(config_json(true), "test");
  const fs::path dir = test::fresh_dir("crash");
  RunOptions options;
  options.out_dir = dir.string();
  options.threads = 2;
  options.quiet = true;
  std::string error;
  try {
    run_campaign(config, options);
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  // The error names both failed runs, the command and what happened.
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    const std::string expected = "run " + run_file(dir.string(), "rich-short", "crash", seed) +
                                 " failed: external optimizer '" + test::kPython + " " +
                                 test::kExternalTestClient + " crash' (seed " +
                                 std::to_string(seed) +
                                 "): the process exited with status 3 before replying to ask 2";
    EXPECT_NE(error.find(expected), std::string::npos) << "'" << expected << "' not in: " << error;
    EXPECT_FALSE(fs::exists(run_file(dir.string(), "rich-short", "crash", seed)));
    // The other runs were written.
    EXPECT_TRUE(fs::exists(run_file(dir.string(), "rich-short", "RS-py", seed)));
    EXPECT_TRUE(fs::exists(run_file(dir.string(), "rich-short", "PSO", seed)));
  }
  EXPECT_NE(error.find("2 of 6 runs failed"), std::string::npos) << error;
  fs::remove_all(dir);
}

// A wave's processes start together: each client writes when its shell started into a file
// of its own (one shared file appended by 4 processes once came back as 3 numbers and a
// fragment), then sleeps 1 s before the Python client runs. Launched one after another at the
// first ask (as before), the starts of 4 runs spread over at least 3 s; launched together,
// over far less.
TEST(ExternalCampaign, WaveProcessesStartTogether) {
  if (!test::python_with_numpy()) GTEST_SKIP() << test::kPython << " with numpy is not available";
  const fs::path dir = test::fresh_dir("launch");
  const fs::path starts = dir / "starts";
  fs::create_directories(starts);
  nlohmann::json j = config_json(false);
  j["algorithms"] = {
      {{"label", "RS-slow"},
       {"name", "external:/usr/bin/python3 -c 'import os, time; open(\"" + starts.string() +
                    "/\" + str(os.getpid()), \"w\").write(repr(time.time()))'; sleep 1; exec " +
                    test::kPython + " " + test::kExternalClient}}};
  j["seeds"] = 4;
  const CampaignConfig config = parse_campaign(j, "test");
  RunOptions options;
  options.out_dir = (dir / "campaign").string();
  options.threads = 2;
  options.quiet = true;
  ASSERT_TRUE(run_campaign(config, options).complete);
  std::vector<double> t;
  for (const auto& entry : fs::directory_iterator(starts)) {
    std::ifstream in(entry.path());
    double x = 0.0;
    ASSERT_TRUE(in >> x) << entry.path() << " holds no start time";
    t.push_back(x);
  }
  ASSERT_EQ(t.size(), 4u);
  const double spread =
      *std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end());
  EXPECT_LT(spread, 1.5) << "the 4 clients started over " << spread << " s";
  std::cout << "the 4 clients started over " << spread << " s\n";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insid::campaign
