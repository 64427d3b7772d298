// Campaign runs in lock-step with the batched kernel (issue 6): the same results as the scalar
// reference evaluator within 1e-9 relative on every run's best fitness, and bit-identical run
// files for 1 and 2 threads.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "bench/campaign.h"

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

nlohmann::json read(const fs::path& p) {
  std::ifstream in(p);
  nlohmann::json j;
  in >> j;
  return j;
}

fs::path run_campaign_into(const std::string& name, int threads, bool scalar) {
  const fs::path dir = fs::temp_directory_path() /
                       ("insid-lockstep-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
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
      nlohmann::json a = read(run_file(one.string(), "rich-short", label, seed));
      nlohmann::json b = read(run_file(two.string(), "rich-short", label, seed));
      const nlohmann::json c = read(run_file(scalar.string(), "rich-short", label, seed));
      // THEN the thread count changes nothing but wall times
      a["result"].erase("wall_s");
      b["result"].erase("wall_s");
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
  auto dir_for = [](const std::string& name) {
    const fs::path dir = fs::temp_directory_path() /
                         ("insid-lockstep-" + name + "-" + std::to_string(getpid()));
    fs::remove_all(dir);
    return dir;
  };
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
      nlohmann::json a = read(run_file(together.string(), "rich-short", label, seed));
      nlohmann::json b = read(run_file(alone.string(), "rich-short", label, seed));
      a["result"].erase("wall_s");
      b["result"].erase("wall_s");
      EXPECT_EQ(a, b) << label << " seed " << seed;
      EXPECT_EQ(a["result"]["evaluations"], 60) << label << " seed " << seed;
    }
  fs::remove_all(together);
  fs::remove_all(alone);
}

}  // namespace
}  // namespace insid::campaign
