// Campaign directories: insid never writes into another program's directory, never outside
// --out, never lets two campaigns share one directory, and cleans its own leftovers.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "base/output_dir.h"
#include "bench/campaign.h"
#include "data/dataset.h"
#include "scenarios/scenario.h"
#include "test_support/files.h"

namespace insid::campaign {
namespace {
namespace fs = std::filesystem;

const char* kConfig = R"({
  "name": "safety",
  "scenarios": [{"name": "short", "preset": "rich", "flight_s": 120, "grade": "nav",
                 "data_seed": 3}],
  "algorithms": [{"label": "PSO", "name": "pso"}],
  "seeds": 2,
  "max_iterations": 2
})";

CampaignConfig config() { return parse_campaign(nlohmann::json::parse(kConfig), "test"); }

RunOptions options_for(const fs::path& dir) {
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  return options;
}

std::string error_of(const CampaignConfig& c, const RunOptions& options) {
  try {
    run_campaign(c, options);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(DirectorySafety, ForeignDirectoryIsRefusedAndKeptUnlessForce) {
  const fs::path dir = test::fresh_dir("foreign");
  fs::create_directories(dir / "src");
  std::ofstream(dir / "src" / "code.c") << "int main;";
  const std::string error = error_of(config(), options_for(dir));
  EXPECT_NE(error.find("not an insid campaign directory: it holds 'src'"), std::string::npos)
      << error;
  EXPECT_NE(error.find("--force"), std::string::npos) << error;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  RunOptions force = options_for(dir);
  force.into_foreign_directory = true;
  EXPECT_TRUE(run_campaign(config(), force).complete);
  EXPECT_EQ(test::read_file(dir / "src" / "code.c"), "int main;");
  // Now a campaign directory: the same campaign resumes without --force.
  EXPECT_TRUE(run_campaign(config(), options_for(dir)).complete);
  fs::remove_all(dir);
}

TEST(DirectorySafety, ConfigNamesThatAreNotPlainNamesAreRefusedBeforeAnyWrite) {
  const fs::path base = test::fresh_dir("names");
  fs::create_directories(base);
  const fs::path dir = base / "a" / "out";
  for (const std::string name : {"../../escape_scn", "", ".", "..", "x/y", "sp ace", "/abs"}) {
    for (const bool is_label : {false, true}) {
      CampaignConfig c = config();
      (is_label ? c.algorithms[0].label : c.scenarios[0].name) = name;
      const std::string error = error_of(c, options_for(dir));
      EXPECT_NE(error.find(std::string(is_label ? "algorithm label" : "scenario name") + " '" +
                           name + "' cannot be used"),
                std::string::npos)
          << name << ": " << error;
      EXPECT_FALSE(fs::exists(base / "a")) << name;  // nothing written, inside or outside
      EXPECT_FALSE(fs::exists(base / "escape_scn")) << name;
    }
  }
  fs::remove_all(base);
}

TEST(DirectorySafety, AnotherCampaignCannotStartWhileOneRuns) {
  const fs::path dir = test::fresh_dir("lock");
  ASSERT_TRUE(run_campaign(config(), options_for(dir)).complete);
  const std::string run_bytes = test::read_file(run_file(dir.string(), "short", "PSO", 1));
  // A campaign running there holds the run lock shared (as run_campaign does).
  FileLock running(dir / FileLock::kRunLockName);
  ASSERT_TRUE(running.try_lock(FileLock::Mode::kShared));
  CampaignConfig other = config();
  other.name = "other";
  RunOptions force_new = options_for(dir);
  force_new.force_new = true;
  const std::string error = error_of(other, force_new);
  EXPECT_NE(error.find("is in use by another insid process"), std::string::npos) << error;
  EXPECT_EQ(test::read_file(run_file(dir.string(), "short", "PSO", 1)), run_bytes);
  // A shard of the same campaign may join (shards of one campaign share the directory); a
  // plain run, which would do every run again, may not.
  const std::string plain_error = error_of(config(), options_for(dir));
  EXPECT_NE(plain_error.find("is in use by another insid process"), std::string::npos)
      << plain_error;
  RunOptions shard = options_for(dir);
  shard.shard = Shard::parse("1/1");
  EXPECT_TRUE(run_campaign(config(), shard).complete);
  // Into a fresh directory whose first campaign has not written its manifest yet.
  const fs::path empty = test::fresh_dir("lock-empty");
  fs::create_directories(empty);
  FileLock starting(empty / FileLock::kRunLockName);
  ASSERT_TRUE(starting.try_lock(FileLock::Mode::kExclusive));
  EXPECT_NE(error_of(config(), options_for(empty)).find("is in use"), std::string::npos);
  running.unlock();
  starting.unlock();
  EXPECT_TRUE(run_campaign(other, force_new).complete);
  fs::remove_all(dir);
  fs::remove_all(empty);
}

// Long enough that the holder still runs while the test tries the directory (it is killed): on
// the exact kernel, as the fast search fitness would end it within a second.
const char* kLongConfig = R"({
  "name": "safety-long",
  "scenarios": [{"name": "short", "preset": "rich", "flight_s": 120, "grade": "nav",
                 "data_seed": 3}],
  "algorithms": [{"label": "PSO", "name": "pso"}],
  "seeds": 40,
  "max_iterations": 400,
  "fitness": "exact"
})";

// Starts `insid bench` on kLongConfig (written to config_path) into dir, as a shard when `shard`
// is not empty, and waits (at most 120 s) until its line is in the directory's run lock.
// Returns its pid, or -1 when fork failed.
pid_t start_long_bench(const fs::path& dir, const fs::path& config_path, const std::string& shard) {
  fs::create_directories(dir);
  std::ofstream(config_path) << kLongConfig;
  const pid_t holder = fork();
  if (holder < 0) return -1;
  if (holder == 0) {
    if (shard.empty())
      execl(INSID_BINARY, INSID_BINARY, "bench", "--config", config_path.c_str(), "--out",
            dir.c_str(), "--threads", "1", static_cast<char*>(nullptr));
    else
      execl(INSID_BINARY, INSID_BINARY, "bench", "--config", config_path.c_str(), "--out",
            dir.c_str(), "--threads", "1", "--shard", shard.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  const fs::path lock = dir / FileLock::kRunLockName;
  const std::string holder_line = "pid " + std::to_string(holder) + " on ";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (test::read_file(lock).find(holder_line) == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  return holder;
}

TEST(DirectorySafety, SecondPlainRunIsRefusedNamingTheHolderUntilTheHolderIsKilled) {
  // GIVEN a plain `insid bench` process running a campaign in dir
  const fs::path dir = test::fresh_dir("holder");
  const fs::path config_path = dir.string() + ".json";
  const CampaignConfig long_config = parse_campaign(nlohmann::json::parse(kLongConfig), "test");
  const pid_t holder = start_long_bench(dir, config_path, "");
  ASSERT_GT(holder, 0);
  const fs::path lock = dir / FileLock::kRunLockName;
  const std::string holder_line = "pid " + std::to_string(holder) + " on ";
  ASSERT_NE(test::read_file(lock).find(holder_line), std::string::npos) << test::read_file(lock);

  // WHEN a second plain run, and a shard, try the same directory, THEN both are refused, the
  // message naming the holder: pid, host, since when, what it does
  const std::string error = error_of(long_config, options_for(dir));
  EXPECT_NE(error.find(dir.string() + " is in use by another insid process"), std::string::npos)
      << error;
  EXPECT_NE(error.find(holder_line), std::string::npos) << error;
  EXPECT_NE(error.find(" since 20"), std::string::npos) << error;
  EXPECT_NE(error.find("Z, all runs"), std::string::npos) << error;
  RunOptions shard = options_for(dir);
  shard.shard = Shard::parse("1/2");
  EXPECT_NE(error_of(long_config, shard).find(holder_line), std::string::npos);

  // WHEN the holder is killed (its lock file still names it), THEN the next plain run takes the
  // directory over and records itself
  kill(holder, SIGKILL);
  int status = 0;
  waitpid(holder, &status, 0);
  ASSERT_NE(test::read_file(lock).find(holder_line), std::string::npos);
  RunOptions next = options_for(dir);
  next.max_new_runs = 1;
  const CampaignOutcome outcome = run_campaign(long_config, next);
  EXPECT_EQ(outcome.new_runs, 1);
  EXPECT_EQ(test::read_file(lock).find(holder_line), std::string::npos) << test::read_file(lock);
  EXPECT_NE(test::read_file(lock).find("pid " + std::to_string(getpid()) + " on "),
            std::string::npos)
      << test::read_file(lock);
  fs::remove_all(dir);
  fs::remove(config_path);
}

TEST(DirectorySafety, ShardRunsOnceAtATimeAndJoinsOnlyShardsOfItsSplit) {
  // GIVEN an `insid bench --shard 1/2` process running in dir
  const fs::path dir = test::fresh_dir("shards");
  const fs::path config_path = dir.string() + ".json";
  const CampaignConfig long_config = parse_campaign(nlohmann::json::parse(kLongConfig), "test");
  const pid_t holder = start_long_bench(dir, config_path, "1/2");
  ASSERT_GT(holder, 0);
  const fs::path lock = dir / FileLock::kRunLockName;
  const std::string holder_line = "pid " + std::to_string(holder) + " on ";
  ASSERT_NE(test::read_file(lock).find(holder_line), std::string::npos) << test::read_file(lock);

  // WHEN the same shard starts again, THEN it is refused naming the running one
  RunOptions same = options_for(dir);
  same.shard = Shard::parse("1/2");
  const std::string same_error = error_of(long_config, same);
  EXPECT_NE(same_error.find("shard 1/2 is already running there"), std::string::npos) << same_error;
  EXPECT_NE(same_error.find(holder_line), std::string::npos) << same_error;
  // WHEN a shard of another split starts, THEN it is refused
  RunOptions other_split = options_for(dir);
  other_split.shard = Shard::parse("2/3");
  const std::string split_error = error_of(long_config, other_split);
  EXPECT_NE(split_error.find("cannot join a campaign split another way"), std::string::npos)
      << split_error;
  // WHEN the other shard of the same split starts, THEN it runs beside the first
  RunOptions second = options_for(dir);
  second.shard = Shard::parse("2/2");
  second.max_new_runs = 1;
  EXPECT_EQ(run_campaign(long_config, second).new_runs, 1);

  kill(holder, SIGKILL);
  int status = 0;
  waitpid(holder, &status, 0);
  // A killed shard's line no longer counts: the same shard may start again.
  same.max_new_runs = 1;
  EXPECT_EQ(run_campaign(long_config, same).new_runs, 1);
  fs::remove_all(dir);
  fs::remove(config_path);
}

TEST(DirectorySafety, RerunRemovesTemporariesLeftByAKill) {
  const fs::path dir = test::fresh_dir("tmp");
  ASSERT_TRUE(run_campaign(config(), options_for(dir)).complete);
  const fs::path run = run_file(dir.string(), "short", "PSO", 1);
  const std::vector<fs::path> leftovers = {run.string() + ".tmp-somehost-12345-0",
                                           dir / "optimum" / "short.json.tmp-h-1-7",
                                           dir / "summary.json.tmp-node-17-3"};
  // A killed write leaves its temporary marked as insid's (base/output_dir.h) and half-written.
  for (const fs::path& p : leftovers) {
    std::ofstream(p) << test::read_file(run).substr(0, 10);
    if (!mark_as_temporary(p)) GTEST_SKIP() << "no user extended attributes: nothing is marked";
  }
  const fs::path users = dir / "runs" / "short" / "PSO" / "notes.tmp-list";  // not insid's pattern
  std::ofstream(users) << "mine";
  // Insid's pattern, but not insid's mark: the user's.
  const fs::path look_alike = dir / "runs" / "short" / "PSO" / "notes.tmp-laptop-12-3";
  std::ofstream(look_alike) << "mine too";
  ASSERT_TRUE(run_campaign(config(), options_for(dir)).complete);
  for (const fs::path& p : leftovers) EXPECT_FALSE(fs::exists(p)) << p;
  EXPECT_TRUE(fs::exists(users));
  EXPECT_EQ(test::read_file(look_alike), "mine too");
  EXPECT_TRUE(fs::exists(run));
  fs::remove_all(dir);
}

TEST(DirectorySafety, CampaignOverDataThatChangedIsADifferentCampaign) {
  const fs::path data = test::fresh_dir("data");
  const fs::path dir = test::fresh_dir("data-campaign");
  scenarios::ScenarioConfig flight = scenarios::preset_scenario("rich");
  flight.flight_s = 120;
  write_dataset(data, scenarios::simulate(flight));
  CampaignConfig c = config();
  c.scenarios[0].preset.clear();
  c.scenarios[0].data_dir = data.string();
  ASSERT_TRUE(run_campaign(c, options_for(dir)).complete);
  EXPECT_TRUE(run_campaign(c, options_for(dir)).complete);  // same data: resumes
  flight.seed += 1;                                         // other noise, same file names
  write_dataset(data, scenarios::simulate(flight));
  const std::string error = error_of(c, options_for(dir));
  EXPECT_NE(error.find("data_sha256"), std::string::npos) << error;
  RunOptions force_new = options_for(dir);
  force_new.force_new = true;
  EXPECT_TRUE(run_campaign(c, force_new).complete);
  fs::remove_all(dir);
  fs::remove_all(data);
}

TEST(DirectorySafety, DamagedRunFileIsNamedAndRedone) {
  const fs::path dir = test::fresh_dir("damaged-run");
  ASSERT_TRUE(run_campaign(config(), options_for(dir)).complete);
  const fs::path run = run_file(dir.string(), "short", "PSO", 1);
  nlohmann::json record = nlohmann::json::parse(test::read_file(run));
  const double fitness = record["result"]["fitness"].get<double>();
  record["result"]["fitness"] = "0.5";  // a string where a number was written
  std::ofstream(run) << record.dump(1);
  const std::string problem = run_file_problem(run, "short", "PSO", 1);
  EXPECT_NE(problem.find(run.string() +
                         ": result.fitness: expected a finite number, found a string \"0.5\""),
            std::string::npos)
      << problem;
  EXPECT_THROW(read_run_record(run, "short", "PSO", 1), std::runtime_error);
  // A key given twice is damage too (the strict reader), and so is another run's record.
  std::ofstream(run) << "{\"schema\": \"insid-run/1\", \"schema\": \"insid-run/1\"}";
  EXPECT_NE(run_file_problem(run, "short", "PSO", 1)
                .find(run.string() + ": schema: key given twice in one object"),
            std::string::npos);
  EXPECT_NE(run_file_problem(run_file(dir.string(), "short", "PSO", 2), "short", "PSO", 1)
                .find(": seed: expected 1 (this run's), found a number 2"),
            std::string::npos);
  // The rerun redoes exactly the damaged run and gets its fitness back (same seed).
  const CampaignOutcome again = run_campaign(config(), options_for(dir));
  EXPECT_TRUE(again.complete);
  EXPECT_EQ(again.new_runs, 1);
  EXPECT_EQ(run_file_problem(run, "short", "PSO", 1), "");
  EXPECT_EQ(nlohmann::json::parse(test::read_file(run))["result"]["fitness"].get<double>(),
            fitness);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insid::campaign
