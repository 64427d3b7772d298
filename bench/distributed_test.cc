// Campaigns split over shards (--shard i/N, insid merge) and over MPI ranks (mpirun -np N):
// the run files must equal a single process's (wall times aside), a killed launch must resume
// without touching finished runs, and bad launches must fail with clear messages. The tests
// drive the built insid binary (and mpirun, when insid is built with MPI).
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support/files.h"
#include "test_support/process.h"

namespace {
namespace fs = std::filesystem;
namespace test = insid::test;

// Two scenarios (so that MPI units of both are in flight and one rank waits for the other's
// optimum), three algorithms, three seeds: 18 runs, a few seconds on one core, searched on the
// exact kernel (the killed-rank test needs runs that last; the fast search fitness would finish
// them all within a blink).
const char* kConfig = R"({
  "name": "test-distributed",
  "scenarios": [{"name": "a", "preset": "rich", "flight_s": 300, "grade": "nav", "data_seed": 3},
                {"name": "b", "preset": "rich", "flight_s": 200, "grade": "nav", "data_seed": 5}],
  "algorithms": [{"label": "PSO", "name": "pso"},
                 {"label": "DVPIO", "name": "dvpio", "parameters": {"dist_threshold": 0.1}},
                 {"label": "GA", "name": "ga"}],
  "seeds": 3,
  "max_iterations": 6,
  "fitness": "exact"
})";
constexpr int kRuns = 18;

class Distributed : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = test::fresh_dir(
        "distributed-test-" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::create_directories(root_);
    config_ = root_ / "campaign.json";
    std::ofstream(config_) << kConfig;
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(root_);
  }

  // `insid bench` on `dir` with extra arguments, as a shell command.
  std::string bench(const fs::path& dir, const std::string& extra = "") const {
    return std::string(INSID_BINARY) + " bench --config " + config_.string() + " --out " +
           dir.string() + " --threads 1 " + extra;
  }

  fs::path root_, config_;
};

// Remove every "wall_s" key (the only fields that depend on timing) at any depth.
void drop_wall_times(nlohmann::json& j) {
  if (j.is_object()) {
    j.erase("wall_s");
    for (auto& item : j.items()) drop_wall_times(item.value());
  } else if (j.is_array()) {
    for (auto& v : j) drop_wall_times(v);
  }
}

// The run files of a campaign directory (relative path -> contents without wall times).
std::map<std::string, nlohmann::json> run_files(const fs::path& dir) {
  std::map<std::string, nlohmann::json> files;
  std::error_code ec;
  if (!fs::exists(dir / "runs", ec)) return files;
  for (const auto& e : fs::recursive_directory_iterator(dir / "runs"))
    if (e.path().extension() == ".json") {
      nlohmann::json j = nlohmann::json::parse(test::read_file(e.path()));
      drop_wall_times(j);
      files[fs::relative(e.path(), dir).string()] = j;
    }
  return files;
}

nlohmann::json summary_without_wall_times(const fs::path& dir) {
  nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "summary.json"));
  drop_wall_times(j);
  return j;
}

// Every run file, the optimum files and the summary of `dir` equal those of `ref`, wall times
// aside.
void expect_same_results(const fs::path& dir, const fs::path& ref) {
  const auto got = run_files(dir), want = run_files(ref);
  ASSERT_EQ(want.size(), static_cast<std::size_t>(kRuns));
  ASSERT_EQ(got.size(), want.size());
  for (const auto& [path, j] : want) {
    ASSERT_TRUE(got.count(path)) << path;
    EXPECT_EQ(got.at(path), j) << path << " differs";
  }
  for (const char* scenario : {"a", "b"}) {
    const fs::path optimum = fs::path("optimum") / (std::string(scenario) + ".json");
    EXPECT_EQ(test::read_file(dir / optimum), test::read_file(ref / optimum)) << optimum;
  }
  ASSERT_TRUE(fs::exists(dir / "summary.json"));
  EXPECT_EQ(summary_without_wall_times(dir), summary_without_wall_times(ref));
}

TEST_F(Distributed, ThreeShardsThenMergeEqualOneProcess) {
  // GIVEN a single-process reference
  const fs::path ref = root_ / "ref", dir = root_ / "sharded";
  ASSERT_EQ(test::shell(bench(ref)), 0);

  // WHEN shards 1/3 and 2/3 have run, merge refuses and lists the runs of shard 3/3 only
  std::string out;
  ASSERT_EQ(test::shell(bench(dir, "--shard 1/3"), &out), 0) << out;
  EXPECT_TRUE(test::contains(out, "incomplete")) << out;
  ASSERT_EQ(test::shell(bench(dir, "--shard 2/3"), &out), 0) << out;
  EXPECT_EQ(run_files(dir).size(), 12u);
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
  EXPECT_NE(test::shell(std::string(INSID_BINARY) + " merge " + dir.string(), &out), 0) << out;
  EXPECT_TRUE(test::contains(out, "6 of 18 runs missing")) << out;
  EXPECT_TRUE(test::contains(out, "shard 3/3 (6): runs/a/PSO/seed_3.json")) << out;
  EXPECT_FALSE(test::contains(out, "shard 1/3")) << out;
  EXPECT_FALSE(test::contains(out, "shard 2/3")) << out;

  // THEN the last shard completes the campaign and writes the summary, merge agrees, and
  // everything equals the single process
  ASSERT_EQ(test::shell(bench(dir, "--shard 3/3"), &out), 0) << out;
  EXPECT_TRUE(test::contains(out, "summary written")) << out;
  fs::remove(dir / "summary.json");
  ASSERT_EQ(test::shell(std::string(INSID_BINARY) + " merge " + dir.string(), &out), 0) << out;
  EXPECT_TRUE(test::contains(out, "all 18 runs present")) << out;
  expect_same_results(dir, ref);
}

TEST_F(Distributed, PlainRunCompletesAShardedDirectory) {
  const fs::path dir = root_ / "sharded";
  std::string out;
  ASSERT_EQ(test::shell(bench(dir, "--shard 2/3"), &out), 0) << out;
  ASSERT_EQ(test::shell(bench(dir), &out), 0) << out;
  EXPECT_TRUE(test::contains(out, "12 new runs, 6 already done, of 18")) << out;
  EXPECT_TRUE(fs::exists(dir / "summary.json"));
}

TEST_F(Distributed, BadShardsAndMergesGetClearErrors) {
  const fs::path dir = root_ / "bad";
  std::string out;
  EXPECT_NE(test::shell(bench(dir, "--shard 0/3"), &out), 0);
  EXPECT_TRUE(
      test::contains(out, "--shard '0/3': shard index 0 is out of range; it must be in 1..3"))
      << out;
  EXPECT_NE(test::shell(bench(dir, "--shard 4/3"), &out), 0);
  EXPECT_TRUE(test::contains(out, "shard index 4 is out of range; it must be in 1..3")) << out;
  EXPECT_NE(test::shell(bench(dir, "--shard 2"), &out), 0);
  EXPECT_TRUE(test::contains(out, "--shard '2': expected i/N")) << out;
  EXPECT_FALSE(fs::exists(dir / "runs"));
  EXPECT_NE(test::shell(std::string(INSID_BINARY) + " merge " + dir.string(), &out), 0);
  EXPECT_TRUE(test::contains(out, "manifest.json")) << out;
  // A shard pointed at another campaign's directory fails like a single process.
  ASSERT_EQ(test::shell(bench(dir, "--max-new-runs 1"), &out), 0) << out;
  nlohmann::json other = nlohmann::json::parse(kConfig);
  other["max_iterations"] = 7;
  std::ofstream(config_) << other.dump();
  EXPECT_NE(test::shell(bench(dir, "--shard 1/2"), &out), 0);
  EXPECT_TRUE(test::contains(out, "holds results of a different campaign")) << out;
  EXPECT_TRUE(test::contains(out, "first difference at config.max_iterations")) << out;
}

TEST_F(Distributed, ShardedSweepMergesIntoSweepTables) {
  const fs::path dir = root_ / "sweep";
  const std::string sweep = std::string(INSID_BINARY) +
                            " sweep --algo dvpio --grid R=0.02,0.2 --preset rich --flight-s 200 "
                            "--seeds 2 --iterations 4 --threads 1 --out " +
                            dir.string();
  std::string out;
  ASSERT_EQ(test::shell(sweep + " --shard 1/2", &out), 0) << out;
  EXPECT_FALSE(fs::exists(dir / "sweep.json"));
  EXPECT_NE(test::shell(std::string(INSID_BINARY) + " merge " + dir.string(), &out), 0);
  EXPECT_TRUE(test::contains(out, "shard 2/2")) << out;
  ASSERT_EQ(test::shell(sweep + " --shard 2/2", &out), 0) << out;
  ASSERT_TRUE(fs::exists(dir / "sweep.json")) << out;
  const std::string sweep_json = test::read_file(dir / "sweep.json"),
                    sweep_csv = test::read_file(dir / "sweep.csv");
  fs::remove(dir / "sweep.json");
  fs::remove(dir / "sweep.csv");
  fs::remove(dir / "summary.json");
  ASSERT_EQ(test::shell(std::string(INSID_BINARY) + " merge " + dir.string(), &out), 0) << out;
  EXPECT_EQ(test::read_file(dir / "sweep.json"), sweep_json);
  EXPECT_EQ(test::read_file(dir / "sweep.csv"), sweep_csv);
  EXPECT_TRUE(fs::exists(dir / "summary.json"));
}

#ifdef INSID_MPIEXEC
// As root in a container: --allow-run-as-root; more ranks than cores: --oversubscribe; no
// binding, so that the ranks' OpenMP threads may use any core.
std::string mpirun(int ranks) {
  return std::string(INSID_MPIEXEC) + " --allow-run-as-root --oversubscribe --bind-to none -np " +
         std::to_string(ranks) + " ";
}

TEST_F(Distributed, MpiTwoAndThreeRanksEqualOneProcess) {
  const fs::path ref = root_ / "ref";
  ASSERT_EQ(test::shell(bench(ref)), 0);
  for (int ranks : {2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const fs::path dir = root_ / ("np" + std::to_string(ranks));
    std::string out;
    ASSERT_EQ(test::shell("timeout 120 " + mpirun(ranks) + bench(dir), &out), 0) << out;
    EXPECT_TRUE(test::contains(out, "18 new runs on " + std::to_string(ranks) + " MPI ranks ("))
        << out;
    // Every rank took work: "(9 + 9)", no rank with 0 runs.
    const auto open = out.find("MPI ranks ("), close = out.find(')', open);
    ASSERT_NE(close, std::string::npos) << out;
    const std::string per_rank = out.substr(open + 11, close - open - 11);
    EXPECT_FALSE(per_rank.starts_with("0 ") || test::contains(per_rank, " 0 ") ||
                 per_rank.ends_with(" 0"))
        << "a rank did no run: " << per_rank;
    const nlohmann::json manifest = nlohmann::json::parse(test::read_file(dir / "manifest.json"));
    EXPECT_EQ(manifest.value("mpi_ranks", 0), ranks);
    expect_same_results(dir, ref);
  }
}

// The ranks (children) of process `parent`.
std::vector<pid_t> children_of(pid_t parent) {
  std::vector<pid_t> pids;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(e.path() / "stat");
    std::string line;
    std::getline(stat, line);
    // pid (comm) state ppid ...: comm may hold spaces, so read after the last ')'.
    const auto close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 2));
    char state = 0;
    pid_t ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent) pids.push_back(static_cast<pid_t>(std::stoi(name)));
  }
  return pids;
}

TEST_F(Distributed, MpiKilledRankResumesWithoutTouchingFinishedRuns) {
  // GIVEN an MPI launch whose rank is killed (SIGKILL) after some runs finished
  const fs::path dir = root_ / "killed", ref = root_ / "ref";
  const pid_t launcher = fork();
  ASSERT_GE(launcher, 0);
  if (launcher == 0) {
    const std::string command =
        mpirun(2) + bench(dir) + " > " + (root_ / "launch.log").string() + " 2>&1";
    execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  auto count_runs = [&] { return static_cast<int>(run_files(dir).size()); };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (count_runs() < 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const std::vector<pid_t> ranks = children_of(launcher);
  ASSERT_FALSE(ranks.empty()) << "no rank of mpirun found";
  kill(ranks.back(), SIGKILL);
  int status = 0;
  waitpid(launcher, &status, 0);
  EXPECT_FALSE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "mpirun reported success";
  const int finished_before = count_runs();
  ASSERT_GE(finished_before, 2);
  ASSERT_LT(finished_before, kRuns) << "the campaign finished before a rank could be killed";
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
  std::map<fs::path, std::pair<std::string, fs::file_time_type>> before;
  for (const auto& e : fs::recursive_directory_iterator(dir / "runs"))
    if (e.path().extension() == ".json")
      before[e.path()] = {test::read_file(e.path()), fs::last_write_time(e.path())};

  // WHEN the same launch is run again
  std::string out;
  ASSERT_EQ(test::shell("timeout 120 " + mpirun(2) + bench(dir), &out), 0) << out;

  // THEN it does only the missing runs, leaves the finished ones untouched, and the results
  // equal an uninterrupted single process's
  EXPECT_TRUE(
      test::contains(out, std::to_string(kRuns - finished_before) + " new runs on 2 MPI ranks"))
      << out;
  EXPECT_TRUE(test::contains(out, ", " + std::to_string(finished_before) + " already done")) << out;
  for (const auto& [path, old] : before) {
    EXPECT_EQ(test::read_file(path), old.first) << path;
    EXPECT_EQ(fs::last_write_time(path), old.second) << path;
  }
  ASSERT_EQ(test::shell(bench(ref)), 0);
  expect_same_results(dir, ref);
}

TEST_F(Distributed, MpiLaunchOnADifferentCampaignFailsOnEveryRank) {
  const fs::path dir = root_ / "other";
  std::string out;
  ASSERT_EQ(test::shell(bench(dir, "--max-new-runs 1"), &out), 0) << out;
  nlohmann::json other = nlohmann::json::parse(kConfig);
  other["max_iterations"] = 7;
  std::ofstream(config_) << other.dump();
  // `timeout`: a rank left waiting for the others would hang the launch.
  const int status = test::shell("timeout 60 " + mpirun(3) + bench(dir), &out);
  EXPECT_NE(status, 0) << out;
  EXPECT_NE(status, 124) << "the launch hung: " << out;
  const std::string message = "first difference at config.max_iterations";
  int copies = 0;
  for (auto at = out.find(message); at != std::string::npos; at = out.find(message, at + 1))
    ++copies;
  EXPECT_EQ(copies, 3) << "every rank should report the error: " << out;
  EXPECT_EQ(run_files(dir).size(), 1u);
}
#else
TEST_F(Distributed, MpiLaunchOfABuildWithoutMpiIsRefused) {
  // What mpirun sets for each of its processes; this build cannot share the work.
  std::string out;
  EXPECT_NE(test::shell("OMPI_COMM_WORLD_SIZE=2 " + bench(root_ / "x")), 0);
  test::shell("OMPI_COMM_WORLD_SIZE=2 " + bench(root_ / "x"), &out);
  EXPECT_TRUE(test::contains(out, "built without MPI")) << out;
  EXPECT_TRUE(test::contains(out, "--shard i/N")) << out;
  EXPECT_FALSE(fs::exists(root_ / "x" / "runs"));
}
#endif

}  // namespace
