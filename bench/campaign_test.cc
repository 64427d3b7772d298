// Campaign harness: schema of the files, resume after a kill, refusal of a different config.
#include "bench/campaign.h"

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <thread>

#include <gtest/gtest.h>

#include "base/json_reader.h"
#include "bench/lockstep_runner.h"
#include "bench/sweep.h"
#include "identification/identify.h"
#include "model/units.h"
#include "test_support/files.h"

namespace insid::campaign {
namespace {
namespace fs = std::filesystem;

const char* kConfig = R"({
  "name": "test-small",
  "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 300, "grade": "nav",
                 "data_seed": 3}],
  "algorithms": [{"label": "PSO", "name": "pso"},
                 {"label": "DVPIO", "name": "dvpio", "parameters": {"dist_threshold": 0.1}}],
  "seeds": 4,
  "max_iterations": 5
})";

// Every field results/README.md documents as required, with its JSON type.
void expect_fields(const nlohmann::json& j, const std::vector<std::pair<std::string, char>>& fields,
                   const std::string& what) {
  for (const auto& [path, type] : fields) {
    const nlohmann::json::json_pointer ptr(path);
    ASSERT_TRUE(j.contains(ptr)) << what << ": missing " << path;
    const nlohmann::json& v = j.at(ptr);
    switch (type) {
      case 'n':
        EXPECT_TRUE(v.is_number()) << what << path;
        break;
      case 's':
        EXPECT_TRUE(v.is_string()) << what << path;
        break;
      case 'a':
        EXPECT_TRUE(v.is_array()) << what << path;
        break;
      case 'o':
        EXPECT_TRUE(v.is_object()) << what << path;
        break;
      default:
        FAIL();
    }
  }
}

CampaignConfig small_config() { return parse_campaign(nlohmann::json::parse(kConfig), "test"); }

// For the kill test: long enough (4 x 6 runs of 20 iterations on a longer flight, searched on the
// exact kernel: the fast search fitness would finish every run before the data's optimum is
// found, and all 24 would be written at once) that the campaign cannot finish between the poll
// that sees the first runs and the kill, even though a lock-step wave finishes several runs at
// once.
const char* kKillConfig = R"({
  "name": "test-kill",
  "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 600, "grade": "nav",
                 "data_seed": 3}],
  "algorithms": [{"label": "PSO", "name": "pso"},
                 {"label": "DVPIO", "name": "dvpio", "parameters": {"dist_threshold": 0.1}},
                 {"label": "GA", "name": "ga"},
                 {"label": "PIO", "name": "pio"}],
  "seeds": 6,
  "max_iterations": 20,
  "fitness": "exact"
})";
constexpr int kKillRuns = 24;

TEST(Campaign, FilesFollowTheDocumentedSchema) {
  const fs::path dir = test::fresh_dir("schema");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  CampaignConfig config = small_config();
  config.uncertainty_replicas = 20;  // off by default in campaigns; the layout when asked for
  const CampaignOutcome outcome = run_campaign(config, options);
  ASSERT_TRUE(outcome.complete);
  EXPECT_EQ(outcome.total_runs, 8);
  const nlohmann::json manifest = test::read_json(dir / "manifest.json");
  EXPECT_EQ(manifest["schema"], "insid-campaign/1");
  expect_fields(manifest,
                {{"/build/git_revision", 's'},
                 {"/host", 's'},
                 {"/cores", 'n'},
                 {"/threads", 'n'},
                 {"/config/name", 's'},
                 {"/config/scenarios", 'a'},
                 {"/config/algorithms", 'a'},
                 {"/config/seeds", 'a'},
                 {"/config/max_iterations", 'n'},
                 {"/config/alignment", 's'},
                 {"/config/estimate", 'a'}},
                "manifest");
  const nlohmann::json run = test::read_json(run_file(dir.string(), "rich-short", "DVPIO", 2));
  EXPECT_EQ(run["schema"], "insid-run/3");
  // Parameters with sd and flags, correlation and the uncertainty's own cost
  expect_fields(run,
                {{"/parameters/0/name", 's'},
                 {"/parameters/0/sd", 'n'},
                 {"/parameters/0/estimate", 'n'},
                 {"/parameters/0/unit_eng", 's'},
                 {"/parameters/0/flags", 'a'},
                 {"/correlation/matrix", 'a'},
                 {"/uncertainty/wall_s", 'n'},
                 {"/uncertainty/evaluations", 'n'}},
                "run uncertainty");
  EXPECT_EQ(run["parameters"].size(), 4u);
  expect_fields(run,
                {{"/scenario", 's'},
                 {"/algorithm", 's'},
                 {"/seed", 'n'},
                 {"/parameters", 'a'},
                 {"/result/algorithm/name", 's'},
                 {"/result/algorithm/parameters", 'o'},
                 {"/result/fitness", 'n'},
                 {"/result/evaluations", 'n'},
                 {"/result/wall_s", 'n'},
                 {"/result/termination", 's'},
                 {"/result/history", 'a'},
                 {"/result/best_per_evaluation", 'a'},
                 {"/estimate", 'o'},
                 {"/estimate_in_sigma_units", 'o'},
                 {"/truth_sigma", 'o'},
                 {"/error_sigma", 'o'},
                 {"/error_vs_optimum_sigma", 'o'},
                 {"/optimum_fitness", 'n'},
                 {"/fitness_gap", 'n'}},
                "run");
  expect_fields(run["result"]["history"][0],
                {{"/iteration", 'n'},
                 {"/evaluations", 'n'},
                 {"/best_fitness", 'n'},
                 {"/median_fitness", 'n'},
                 {"/diversity", 'n'},
                 {"/phase", 's'},
                 {"/d_positive_sigma", 'a'},
                 {"/d_negative_sigma", 'a'}},
                "history");
  EXPECT_EQ(run["result"]["best_per_evaluation"].size(),
            run["result"]["evaluations"].get<std::size_t>());
  const nlohmann::json summary = test::read_json(dir / "summary.json");
  EXPECT_EQ(summary["schema"], "insid-summary/1");
  const std::string a = "/scenarios/rich-short/algorithms/PSO";
  expect_fields(summary,
                {{a + "/runs", 'n'},
                 {a + "/final_fitness/median", 'n'},
                 {a + "/final_fitness/q1", 'n'},
                 {a + "/final_fitness/q3", 'n'},
                 {a + "/error_sigma/gyro_bias_x/median_abs", 'n'},
                 {a + "/success", 'a'},
                 {a + "/curve_iterations/median", 'a'},
                 {a + "/curve_evaluations/x", 'a'},
                 {a + "/wall_s/median", 'n'},
                 {"/scenarios/rich-short/pairwise", 'a'},
                 {"/scenarios/rich-short/ranking", 'a'}},
                "summary");
  const nlohmann::json& pw = summary["scenarios"]["rich-short"]["pairwise"][0];
  expect_fields(pw,
                {{"/U", 'n'},
                 {"/p", 'n'},
                 {"/p_holm", 'n'},
                 {"/a12", 'n'},
                 {"/a12_magnitude", 's'},
                 {"/method", 's'}},
                "pairwise");
  fs::remove_all(dir);
}

// GIVEN a campaign searched with the fast fitness (the default) and the same one with --fitness
// exact. THEN every run's reported fitness is the exact kernel's Eq. 15 of its best point (the
// search's value, recorded beside it, differs from it), the record says which fitness did what,
// and on this navigation-grade flight both searches end at the same final fitness (issue 47).
TEST(Campaign, TheExactKernelScoresEveryReportedFitness) {
  const fs::path dir = test::fresh_dir("fitness");
  RunOptions options;
  options.out_dir = (dir / "fast").string();
  options.quiet = true;
  CampaignConfig config = small_config();
  ASSERT_EQ(config.search_fitness, SearchFitnessKind::kFast);
  ASSERT_TRUE(run_campaign(config, options).complete);
  config.search_fitness = SearchFitnessKind::kExact;
  options.out_dir = (dir / "exact").string();
  ASSERT_TRUE(run_campaign(config, options).complete);
  EXPECT_EQ(test::read_json(dir / "fast" / "manifest.json")["config"]["fitness"], "fast");
  EXPECT_EQ(test::read_json(dir / "exact" / "manifest.json")["config"]["fitness"], "exact");

  const ParameterMapping mapping(estimated_parameters(config));
  const auto navigation = std::make_shared<const NavigationProblem>(
      scenario_dataset(config.scenarios.front()), config.navigation_options());
  const InsIdentificationProblem exact(navigation, mapping);
  for (const std::uint64_t seed : config.seeds)
    for (const char* label : {"PSO", "DVPIO"}) {
      const nlohmann::json fast =
          test::read_json(run_file((dir / "fast").string(), "rich-short", label, seed));
      const nlohmann::json slow =
          test::read_json(run_file((dir / "exact").string(), "rich-short", label, seed));
      EXPECT_EQ(fast["search_fitness"]["used"], "fast");
      EXPECT_EQ(fast["search_fitness"]["reported"], "exact");
      EXPECT_EQ(slow["search_fitness"]["used"], "exact");
      const Eigen::VectorXd x = mapping.from_sigma(estimate_in_sigma_units(fast, mapping));
      std::vector<double> f(1);
      exact.evaluate_batch(std::span(&x, 1), f);
      const double reported = fast["result"]["fitness"].get<double>();
      const double searched = fast["search_fitness"]["best_f_search"].get<double>();
      EXPECT_NEAR(reported, f[0], 1e-9 * f[0]) << label << " seed " << seed;
      EXPECT_GT(std::abs(searched - reported), 1e-9 * reported) << label << " seed " << seed;
      EXPECT_NEAR(reported, slow["result"]["fitness"].get<double>(), 1e-4 * reported)
          << label << " seed " << seed;
      // The exact search's record: its search value is its reported one.
      EXPECT_EQ(slow["search_fitness"]["best_f_search"], slow["result"]["fitness"]);
    }
  fs::remove_all(dir);
}

TEST(Campaign, DifferentConfigIsRefusedUnlessForceNew) {
  const fs::path dir = test::fresh_dir("mismatch");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  options.max_new_runs = 1;
  run_campaign(small_config(), options);
  CampaignConfig other = small_config();
  other.max_iterations = 6;
  try {
    run_campaign(other, options);
    FAIL() << "a different config was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("config.max_iterations"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--force-new"), std::string::npos);
  }
  options.force_new = true;
  EXPECT_NO_THROW(run_campaign(other, options));
  fs::remove_all(dir);
}

TEST(Campaign, RunFilesOfTheOldSchemaStillResume) {
  // GIVEN a finished campaign with one run written before insid-run/2 (the estimate in sigma
  // units was "estimate_sigma")
  const fs::path dir = test::fresh_dir("old-run-schema");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  ASSERT_TRUE(run_campaign(small_config(), options).complete);
  const fs::path file = run_file(dir.string(), "rich-short", "PSO", 1);
  nlohmann::json run = test::read_json(file);
  ASSERT_EQ(run["schema"], "insid-run/3");
  run["schema"] = "insid-run/1";
  run["estimate_sigma"] = run["estimate_in_sigma_units"];
  run.erase("estimate_in_sigma_units");
  std::ofstream(file) << run.dump(1);
  const std::string old_bytes = test::read_file(file);
  // THEN it is kept: not redone, not rewritten, and the summary is written again
  fs::remove(dir / "summary.json");
  const CampaignOutcome outcome = run_campaign(small_config(), options);
  EXPECT_EQ(outcome.skipped_runs, 8);
  EXPECT_EQ(outcome.new_runs, 0);
  EXPECT_TRUE(outcome.complete);
  EXPECT_TRUE(fs::exists(dir / "summary.json"));
  EXPECT_EQ(test::read_file(file), old_bytes);
  // ...but a schema that is neither is redone
  run["schema"] = "insid-run/0";
  std::ofstream(file) << run.dump(1);
  const CampaignOutcome redo = run_campaign(small_config(), options);
  EXPECT_EQ(redo.new_runs, 1);
  EXPECT_EQ(test::read_json(file)["schema"], "insid-run/3");
  // ...and an insid-run/2 record (parameters listed by name, no sd) is kept as well
  nlohmann::json previous = test::read_json(file);
  previous["schema"] = "insid-run/2";
  previous["parameters"] = {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y"};
  std::ofstream(file) << previous.dump(1);
  const std::string previous_bytes = test::read_file(file);
  EXPECT_EQ(run_campaign(small_config(), options).new_runs, 0);
  EXPECT_EQ(test::read_file(file), previous_bytes);
  fs::remove_all(dir);
}

TEST(Campaign, ManifestWithoutANewDefaultParameterStillResumes) {
  // GIVEN a directory whose manifest was written before DVPIO had shrink_without_gain
  const fs::path dir = test::fresh_dir("added-default");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  options.max_new_runs = 2;
  run_campaign(small_config(), options);
  nlohmann::json manifest = test::read_json(dir / "manifest.json");
  nlohmann::json& dvpio = manifest["config"]["algorithms"][1];
  ASSERT_EQ(dvpio["name"], "dvpio");
  ASSERT_EQ(dvpio["parameters"].erase("shrink_without_gain"), 1u);
  std::ofstream(dir / "manifest.json") << manifest.dump(2);
  // THEN the same campaign resumes (the parameter is at its default: same results)...
  options.max_new_runs = 0;
  const CampaignOutcome outcome = run_campaign(small_config(), options);
  EXPECT_EQ(outcome.skipped_runs, 2);
  EXPECT_TRUE(outcome.complete);
  // ...and merges; but the variant switched on is a different campaign
  std::ofstream(dir / "manifest.json") << manifest.dump(2);
  EXPECT_NO_THROW(merge_results(dir.string()));
  std::ofstream(dir / "manifest.json") << manifest.dump(2);
  CampaignConfig variant = small_config();
  variant.algorithms[1].parameters["shrink_without_gain"] = 1;
  try {
    run_campaign(variant, options);
    FAIL() << "a config with the variant switched on was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("shrink_without_gain"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Campaign, KilledCampaignResumesWithoutTouchingFinishedRuns) {
  // GIVEN a campaign process killed (SIGKILL) after some runs finished
  const fs::path dir = test::fresh_dir("kill");
  const fs::path ref = test::fresh_dir("kill-ref");
  fs::create_directories(dir);
  const fs::path config_path = dir.string() + ".json";
  std::ofstream(config_path) << kKillConfig;
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(INSID_BINARY, INSID_BINARY, "bench", "--config", config_path.c_str(), "--out",
          dir.c_str(), "--threads", "1", static_cast<char*>(nullptr));
    _exit(127);
  }
  const fs::path runs = dir / "runs" / "rich-short";
  auto count_runs = [&] {
    int n = 0;
    std::error_code ec;
    if (!fs::exists(runs, ec)) return 0;
    for (const auto& e : fs::recursive_directory_iterator(runs, ec))
      if (e.path().extension() == ".json") ++n;
    return n;
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(240);
  while (count_runs() < 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  const int finished_before = count_runs();
  ASSERT_GE(finished_before, 2);
  ASSERT_LT(finished_before, kKillRuns) << "the campaign finished before it could be killed";
  std::map<fs::path, std::pair<std::string, fs::file_time_type>> before;
  for (const auto& e : fs::recursive_directory_iterator(runs))
    if (e.path().extension() == ".json")
      before[e.path()] = {test::read_file(e.path()), fs::last_write_time(e.path())};

  // WHEN the same campaign is run again on the directory
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(kKillConfig), "test");
  const CampaignOutcome resumed = run_campaign(config, options);

  // THEN finished runs are skipped and untouched, the rest done, and every run equals an
  // uninterrupted campaign's (wall times aside).
  EXPECT_TRUE(resumed.complete);
  EXPECT_EQ(resumed.skipped_runs, finished_before);
  EXPECT_EQ(resumed.new_runs, kKillRuns - finished_before);
  for (const auto& [path, old] : before) {
    EXPECT_EQ(test::read_file(path), old.first) << path;
    EXPECT_EQ(fs::last_write_time(path), old.second) << path;
  }
  RunOptions ref_options;
  ref_options.out_dir = ref.string();
  ref_options.quiet = true;
  ref_options.threads = 2;
  ASSERT_TRUE(run_campaign(config, ref_options).complete);
  for (const char* label : {"PSO", "DVPIO", "GA", "PIO"})
    for (std::uint64_t seed = 1; seed <= 6; ++seed) {
      nlohmann::json a = test::read_json(run_file(dir.string(), "rich-short", label, seed));
      nlohmann::json b = test::read_json(run_file(ref.string(), "rich-short", label, seed));
      a["result"].erase("wall_s");
      if (a.contains("uncertainty")) a["uncertainty"].erase("wall_s");  // timing
      b["result"].erase("wall_s");
      if (b.contains("uncertainty")) b["uncertainty"].erase("wall_s");  // timing
      EXPECT_EQ(a, b) << label << " seed " << seed;
    }
  fs::remove_all(dir);
  fs::remove_all(ref);
  fs::remove(config_path);
}

// The message of the std::invalid_argument that reading the config file with `text` throws, or
// "(accepted)".
std::string config_file_error(const std::string& text) {
  const fs::path path = test::fresh_dir("config-file").string() + ".json";
  std::ofstream(path) << text;
  std::string error = "(accepted)";
  try {
    read_campaign_file(path.string());
  } catch (const std::invalid_argument& e) {
    error = e.what();
  }
  fs::remove(path);
  return error;
}

// The one typed reader's wording (base/json_object.h): the file, the field's path, what was
// expected and what was found, for each kind of fault of a campaign config file.
TEST(Campaign, ConfigFileFaultsAreNamedWithTheFieldPath) {
  const std::string path = test::fresh_dir("config-file").string() + ".json";
  const std::string algorithms = R"("algorithms": [{"name": "pso"}], "max_iterations": 2)";
  // GIVEN a good config file THEN it reads
  EXPECT_EQ(
      config_file_error(R"({"scenarios": [{"name": "s", "preset": "rich"}], )" + algorithms + "}"),
      "(accepted)");
  // an unknown key, with the valid ones
  EXPECT_EQ(config_file_error(R"({"scenarios": [{"name": "s", "preset": "rich"},
                                               {"name": "t", "preset": "rich", "colour": 1}], )" +
                              algorithms + "}"),
            path +
                ": scenarios[1].colour: unknown key (valid keys: name, preset, data, flight_s, "
                "grade, data_seed, set)");
  // a missing key
  EXPECT_EQ(config_file_error(R"({"scenarios": [{"preset": "rich"}], )" + algorithms + "}"),
            path + ": scenarios[0].name: missing, expected a string");
  // a wrong type
  EXPECT_EQ(config_file_error(R"({"scenarios": [{"name": "s", "preset": "rich",
                                                "flight_s": "long"}], )" +
                              algorithms + "}"),
            path + ": scenarios[0].flight_s: expected a number, found a string \"long\"");
  // a key given twice (refused by the strict parser, in the same wording)
  EXPECT_EQ(config_file_error(R"({"scenarios": [{"name": "s", "preset": "rich",
                                                "name": "t"}], )" +
                              algorithms + "}"),
            path +
                ": scenarios[0].name: key given twice in one object (JSON objects must not "
                "repeat a key)");
}

TEST(Campaign, EveryCommittedConfigAndManifestStillReads) {
  // Files insid wrote earlier (results/: campaign configs and manifests of old schemas) read
  // with today's reader.
  int configs = 0, manifests = 0;
  for (const auto& entry :
       fs::recursive_directory_iterator(fs::path(INSID_SOURCE_DIR) / "results")) {
    const fs::path& p = entry.path();
    if (p.extension() != ".json") continue;
    if (p.parent_path().filename() == "configs") {
      EXPECT_NO_THROW(read_campaign_file(p.string())) << p;
      ++configs;
    } else if (p.filename() == "manifest.json") {
      EXPECT_NO_THROW(config_from_manifest(read_json_file(p), p.string())) << p;
      ++manifests;
    }
  }
  EXPECT_GE(configs, 10);
  EXPECT_GE(manifests, 10);
}

TEST(Campaign, BadConfigsGetClearErrors) {
  nlohmann::json j = nlohmann::json::parse(kConfig);
  j["colour"] = "blue";
  try {
    parse_campaign(j, "c.json");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("c.json: colour: unknown key (valid keys: name, "
                                         "scenarios, algorithms, seeds, "),
              std::string::npos)
        << e.what();
  }
  j = nlohmann::json::parse(kConfig);
  j["algorithms"][0]["parameters"] = {{"w", 1.7}};
  EXPECT_THROW(parse_campaign(j, "c.json"), std::invalid_argument);
  j = nlohmann::json::parse(kConfig);
  j["algorithms"][1]["label"] = "PSO";
  EXPECT_THROW(parse_campaign(j, "c.json"), std::invalid_argument);
  EXPECT_THROW(preset_campaign("paper-fig10"), std::invalid_argument);
  EXPECT_THROW(SweepAxis::parse("R=0.3:0.1:4"), std::invalid_argument);
  EXPECT_THROW(SweepAxis::parse("R"), std::invalid_argument);
  const SweepAxis axis = SweepAxis::parse("R=0.01:0.03:3");
  ASSERT_EQ(axis.values.size(), 3u);
  EXPECT_DOUBLE_EQ(axis.values[1], 0.02);
}

// The message of the std::invalid_argument that `f` throws ("" when it throws none).
template <typename F>
std::string invalid_argument_of(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Campaign, OptionsAreValidatedBeforeAnyWorkNamingTheBadValue) {
  // GIVEN a valid campaign and options for a directory that does not exist
  const fs::path dir = test::fresh_dir("validate");
  const CampaignConfig good = parse_campaign(nlohmann::json::parse(kConfig), "c.json");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  EXPECT_EQ(options.validate(), "");
  EXPECT_NO_THROW(good.validate("c.json"));
  // WHEN one value is bad THEN the error names it, and nothing is written
  const auto campaign_error = [&](const CampaignConfig& config, const RunOptions& o) {
    return invalid_argument_of([&] { run_campaign(config, o); });
  };
  RunOptions bad = options;
  bad.threads = -2;
  EXPECT_NE(campaign_error(good, bad).find("threads must be >= 0 (0 = all cores), got -2"),
            std::string::npos);
  bad = options;
  bad.max_new_runs = -1;
  EXPECT_NE(campaign_error(good, bad).find("max_new_runs must be >= 0"), std::string::npos);
  for (const double wave_s : {-1.0, std::nan("")}) {
    bad = options;
    bad.max_wave_s = wave_s;
    EXPECT_NE(campaign_error(good, bad).find("max_wave_s must be a finite number >= 0"),
              std::string::npos)
        << wave_s;
  }
  bad = options;
  bad.shard.index = 3;
  bad.shard.count = 2;
  EXPECT_NE(campaign_error(good, bad).find("shard 3/2 is out of range"), std::string::npos);
  bad = options;
  bad.shard = Shard::parse("1/2");
  bad.force_new = true;
  EXPECT_NE(campaign_error(good, bad).find("--force-new cannot be combined with --shard"),
            std::string::npos);
  CampaignConfig config = good;
  config.max_evaluations = -5;
  EXPECT_NE(campaign_error(config, options).find("max_evaluations must be >= 0, got -5"),
            std::string::npos);
  config = good;
  config.record_positions_seeds = -1;
  EXPECT_NE(campaign_error(config, options).find("record_positions_seeds must be >= 0, got -1"),
            std::string::npos);
  config = good;
  config.scenarios[0].grade = "consumer";
  EXPECT_NE(campaign_error(config, options).find("scenarios[0]"), std::string::npos);
  EXPECT_NE(campaign_error(config, options).find("consumer"), std::string::npos);
  config = good;
  config.scenarios[0].preset = "moon-landing";
  EXPECT_NE(campaign_error(config, options).find("moon-landing"), std::string::npos);
  config = good;
  config.scenarios[0].flight_s = -300.0;
  EXPECT_NE(campaign_error(config, options).find("scenarios[0].flight_s must be a positive"),
            std::string::npos);
  config = good;
  config.seeds = {1, 2, 1};
  EXPECT_NE(campaign_error(config, options).find("seed 1 is listed twice"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir));
  // AND a sweep's settings likewise
  SweepConfig sweep;
  sweep.scenario.name = "rich";
  sweep.scenario.preset = "rich";
  EXPECT_NE(sweep.validate().find("give at least one --grid"), std::string::npos);
  EXPECT_NE(
      invalid_argument_of([&] { run_sweep(sweep, options); }).find("give at least one --grid"),
      std::string::npos);
  sweep.axes = {SweepAxis::parse("R=0.02,0.2")};
  EXPECT_EQ(sweep.validate(), "");
  sweep.random_settings = -3;
  EXPECT_NE(
      invalid_argument_of([&] { run_sweep(sweep, options); }).find("--random must be >= 0, got -3"),
      std::string::npos);
  sweep.random_settings = 0;
  sweep.max_iterations = -1;
  EXPECT_NE(invalid_argument_of([&] {
              run_sweep(sweep, options);
            }).find("--iterations must be >= 0, got -1"),
            std::string::npos);
  sweep.max_iterations = 40;
  sweep.seeds.clear();
  EXPECT_NE(invalid_argument_of([&] { run_sweep(sweep, options); }).find("sweep: no seed"),
            std::string::npos);
  sweep.seeds = seed_range(2);
  sweep.axes[0].values.clear();
  EXPECT_NE(invalid_argument_of([&] { run_sweep(sweep, options); }).find("--grid R: no values"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir));
}

TEST(Campaign, SweepGridKeepsTheAlgorithmsOwnSigmaParameters) {
  // A _sigma key that is the algorithm's own parameter (ekf-rts's initial_bias_sigma, a prior
  // in catalogue sigma) passes unchanged; a DVPIO distance in sigma is converted to the box.
  SweepConfig ekf;
  ekf.algorithm = "ekf-rts";
  ekf.axes = {SweepAxis::parse("initial_bias_sigma=2,8")};
  ekf.scenario.name = "rich";
  ekf.scenario.preset = "rich";
  ekf.seeds = seed_range(1);
  const CampaignConfig ekf_campaign = sweep_campaign(ekf);
  ASSERT_EQ(ekf_campaign.algorithms.size(), 2u);
  EXPECT_EQ(ekf_campaign.algorithms[1].parameters.at("initial_bias_sigma"), 8.0);
  EXPECT_EQ(ekf_campaign.algorithms[1].parameters.count("initial_bias"), 0u);
  SweepConfig dvpio = ekf;
  dvpio.algorithm = "dvpio";
  dvpio.axes = {SweepAxis::parse("dist_threshold_sigma=0.4")};
  EXPECT_DOUBLE_EQ(sweep_campaign(dvpio).algorithms[0].parameters.at("dist_threshold"), 0.1);
}

TEST(Campaign, SweepWritesPerSettingStatistics) {
  const fs::path dir = test::fresh_dir("sweep");
  SweepConfig sweep;
  sweep.algorithm = "dvpio";
  sweep.axes = {SweepAxis::parse("R=0.02,0.2"), SweepAxis::parse("d0_sigma=0.05")};
  sweep.scenario.name = "rich";
  sweep.scenario.preset = "rich";
  sweep.scenario.flight_s = 300;
  sweep.seeds = seed_range(3);
  sweep.max_iterations = 4;
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  ASSERT_TRUE(run_sweep(sweep, options).complete);
  const nlohmann::json s = test::read_json(dir / "sweep.json");
  EXPECT_EQ(s["schema"], "insid-sweep/1");
  ASSERT_EQ(s["settings"].size(), 2u);
  EXPECT_DOUBLE_EQ(s["settings"][1]["parameters"]["R"].get<double>(), 0.2);
  // d0_sigma = 0.05 sigma is 0.0125 in the normalised [-4, 4] sigma box.
  const nlohmann::json manifest = test::read_json(dir / "manifest.json");
  EXPECT_DOUBLE_EQ(manifest["config"]["algorithms"][0]["parameters"]["d_initial"].get<double>(),
                   0.0125);
  const double lo = s["settings"][0]["median_ci95"][0], hi = s["settings"][0]["median_ci95"][1];
  const double med = s["settings"][0]["final_fitness"]["median"];
  EXPECT_LE(lo, med);
  EXPECT_GE(hi, med);
  EXPECT_TRUE(fs::exists(dir / "sweep.csv"));
  fs::remove_all(dir);
}

TEST(Campaign, RunFileAndIdentifyRecordTheSameAssessment) {
  // GIVEN a dataset directory, a one-run campaign over it and `insid identify` on it with the
  // same algorithm, seed and budget
  const fs::path dir = test::fresh_dir("record");
  fs::create_directories(dir);
  const fs::path data = dir / "data";
  const fs::path identified = dir / "identify.json";
  const std::string insid = INSID_BINARY;
  ASSERT_EQ(
      std::system((insid + " simulate --preset rich --flight-s 300 --grade nav --seed 3 --out " +
                   data.string() + " 2>/dev/null")
                      .c_str()),
      0);
  const nlohmann::json config_json = {{"name", "record"},
                                      {"scenarios", {{{"name", "data"}, {"data", data.string()}}}},
                                      {"algorithms", {{{"label", "DVPIO"}, {"name", "dvpio"}}}},
                                      {"seeds", {2}},
                                      {"max_iterations", 5}};
  RunOptions options;
  options.out_dir = (dir / "campaign").string();
  options.quiet = true;
  ASSERT_TRUE(run_campaign(parse_campaign(config_json, "test"), options).complete);
  ASSERT_EQ(std::system((insid + " identify --data " + data.string() +
                         " --algo dvpio --seed 2 --iterations 5 --out " + identified.string() +
                         " 2>/dev/null")
                            .c_str()),
            0);
  const nlohmann::json run = test::read_json(run_file(options.out_dir, "data", "DVPIO", 2));
  const nlohmann::json id = test::read_json(identified);
  // THEN both carry every assessment field (results/README.md), with the same values
  for (const char* key :
       {"estimate", "estimate_in_sigma_units", "truth_sigma", "error_sigma",
        "error_vs_optimum_sigma", "optimum_fitness", "fitness_gap", "fitness_gap_relative"}) {
    ASSERT_TRUE(run.contains(key)) << "run file lacks " << key;
    ASSERT_TRUE(id.contains(key)) << "identify result lacks " << key;
    EXPECT_EQ(run[key], id[key]) << key;
  }
  EXPECT_EQ(run["result"]["fitness"], id["fitness"]);
  fs::remove_all(dir);
}

// GIVEN one flight WHEN `insid identify` runs on it with its defaults and a campaign is set up on
// it with its defaults (no "initial_attitude", no "estimate") THEN both estimate the same
// parameters (name, sigma, box) and check gyrocompassing against the same gyro bias allowance:
// the expected heading sd identify records equals the campaign's navigation problem's. And for
// a grade given to both (tactical), the same set and allowance (identify's spec, which the CLI
// fills from its arguments, against the campaign's config): one rule, gyro_bias_allowance_rad_s,
// not the catalogue's 0.01 deg/h for a campaign without "initial_attitude" where identify used
// the box's 0.04 deg/h (nav) or 4 deg/h (tactical).
TEST(Campaign, IdentifyAndACampaignOnOneFlightShareDefaultSetAndGyroBiasAllowance) {
  const fs::path dir = test::fresh_dir("same-flight");
  fs::create_directories(dir);
  const fs::path data = dir / "data";
  const fs::path identified = dir / "identify.json";
  const std::string insid = INSID_BINARY;
  ASSERT_EQ(
      std::system((insid + " simulate --preset straight --flight-s 60 --grade nav --seed 5 --out " +
                   data.string() + " 2>/dev/null")
                      .c_str()),
      0);
  ASSERT_EQ(std::system((insid + " identify --data " + data.string() +
                         " --algo pso --iterations 1 --no-reference-optimum "
                         "--uncertainty-replicas 0 --out " +
                         identified.string() + " 2>/dev/null")
                            .c_str()),
            0);
  const nlohmann::json id = test::read_json(identified);
  CampaignConfig config =
      parse_campaign({{"name", "same-flight"},
                      {"scenarios", {{{"name", "data"}, {"data", data.string()}}}},
                      {"algorithms", {{{"label", "PSO"}, {"name", "pso"}}}},
                      {"seeds", {1}},
                      {"max_iterations", 1}},
                     "test");
  const std::vector<EstimatedParameter> campaign_set = estimated_parameters(config);
  ASSERT_EQ(id["estimated"].size(), campaign_set.size());
  for (std::size_t k = 0; k < campaign_set.size(); ++k) {
    EXPECT_EQ(id["estimated"][k]["name"], campaign_set[k].name);
    EXPECT_EQ(id["estimated"][k]["sigma"].get<double>(), campaign_set[k].sigma);
    EXPECT_EQ(id["estimated"][k]["lower_sigma"].get<double>(), campaign_set[k].lower_sigma);
    EXPECT_EQ(id["estimated"][k]["upper_sigma"].get<double>(), campaign_set[k].upper_sigma);
  }
  const NavigationProblem campaign_navigation(scenario_dataset(config.scenarios[0]),
                                              config.navigation_options());
  ASSERT_TRUE(campaign_navigation.initial_attitude_source().feasibility().has_value());
  ASSERT_TRUE(id["initial_attitude"].contains("gyrocompass_heading_sd_deg")) << id.dump();
  EXPECT_EQ(id["initial_attitude"]["gyrocompass_heading_sd_deg"].get<double>(),
            campaign_navigation.initial_attitude_source().feasibility()->heading_sd_rad * kRadToDeg)
      << id["initial_attitude"]["gyrocompass_check"];

  // A grade given to both: identify's spec as `insid identify --grade tactical` fills it.
  IdentifySpec spec;
  spec.data_dir = data.string();
  spec.grade = "tactical";
  const IdentifySetup setup = identify_setup(spec, *scenario_dataset(config.scenarios[0]));
  config.estimation_grade = "tactical";
  const std::vector<EstimatedParameter> tactical = estimated_parameters(config);
  ASSERT_EQ(setup.estimated.size(), tactical.size());
  for (std::size_t k = 0; k < tactical.size(); ++k) {
    EXPECT_EQ(setup.estimated[k].name, tactical[k].name);
    EXPECT_EQ(setup.estimated[k].sigma, tactical[k].sigma);
  }
  EXPECT_EQ(setup.navigation.initial_attitude.gyro_bias_allowance_rad_s,
            config.navigation_options().initial_attitude.gyro_bias_allowance_rad_s);
  EXPECT_DOUBLE_EQ(setup.navigation.initial_attitude.gyro_bias_allowance_rad_s,
                   4.0 * sensor_grade("tactical").gyro_bias_rad_s);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insid::campaign

namespace insid::campaign {
namespace {

// A MEMS campaign: the rich flight with mems noise and MEMS-size biases, searched
// in a MEMS box (0.1 deg/s, 10 mg units).
const char* kMemsConfig = R"({
  "name": "test-mems",
  "scenarios": [{"name": "rich-mems", "preset": "rich", "flight_s": 120, "grade": "mems",
                 "data_seed": 2, "set": {"gyro_bias_x": 0.00349, "gyro_bias_y": -0.00262,
                                         "accel_bias_x": 0.196, "accel_bias_y": -0.147}}],
  "algorithms": [{"label": "PSO", "name": "pso"}],
  "seeds": 1,
  "max_iterations": 2,
  "estimate": ["accel_bias_x:0.0980665", "accel_bias_y:0.0980665",
               "gyro_bias_x:0.001745", "gyro_bias_y:0.001745"]
})";

// A one-axis PSO sweep on the rich preset (the keys' pass-through checks).
SweepConfig rich_pso_sweep() {
  SweepConfig sweep;
  sweep.algorithm = "pso";
  sweep.axes.push_back(SweepAxis::parse("w=0.5"));
  sweep.scenario.name = "rich";
  sweep.scenario.preset = "rich";
  return sweep;
}

// GIVEN a MEMS campaign without the new keys THEN it is refused by the gyrocompass feasibility
// check, as before (configs always gyrocompassed); WITH "initial_attitude": "level+heading" and
// "window_s": 10 THEN it runs, and the resolved config and every run file record both. A config
// without the keys resolves to the same JSON as before (no new key), so older campaign
// directories still resume; bad values are named.
TEST(Campaign, MemsCampaignRunsWithLevelHeadingAndAWindow) {
  nlohmann::json j = nlohmann::json::parse(kMemsConfig);
  const CampaignConfig old_style = parse_campaign(j, "mems.json");
  EXPECT_FALSE(old_style.to_json().contains("initial_attitude"));
  EXPECT_FALSE(old_style.to_json().contains("window_s"));
  EXPECT_FALSE(old_style.to_json().contains("heading_deg"));
  const fs::path dir = test::fresh_dir("mems");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  std::string refused;
  try {
    run_campaign(old_style, options);
  } catch (const std::exception& e) {
    refused = e.what();
  }
  EXPECT_NE(refused.find("level+heading"), std::string::npos) << refused;
  fs::remove_all(dir);

  j["initial_attitude"] = "level+heading";
  j["window_s"] = 10.0;
  const CampaignConfig mems = parse_campaign(j, "mems.json");
  EXPECT_EQ(mems.to_json()["initial_attitude"], "level+heading");
  EXPECT_EQ(mems.to_json()["window_s"], 10.0);
  EXPECT_EQ(mems.navigation_options().initial_attitude.mode, InitialAttitudeMode::kLevelHeading);
  EXPECT_EQ(mems.navigation_options().window_s, 10.0);
  // The feasibility allowance meets the box (4 x 0.1 deg/s), as identify's does.
  EXPECT_NEAR(mems.navigation_options().initial_attitude.gyro_bias_allowance_rad_s, 4 * 0.001745,
              1e-12);
  ASSERT_TRUE(run_campaign(mems, options).complete);
  const nlohmann::json manifest = test::read_json(dir / "manifest.json");
  EXPECT_EQ(manifest["config"]["initial_attitude"], "level+heading");
  EXPECT_EQ(manifest["config"]["window_s"], 10.0);
  const nlohmann::json run = test::read_json(run_file(dir.string(), "rich-mems", "PSO", 1));
  EXPECT_EQ(run["initial_attitude"], "level+heading");
  EXPECT_EQ(run["window_s"], 10.0);
  EXPECT_TRUE(std::isfinite(run["result"]["fitness"].get<double>()));
  fs::remove_all(dir);

  nlohmann::json bad = nlohmann::json::parse(kMemsConfig);
  bad["initial_attitude"] = "compass";
  EXPECT_NE(invalid_argument_of([&] { parse_campaign(bad, "m.json"); }).find("compass"),
            std::string::npos);
  bad = nlohmann::json::parse(kMemsConfig);
  bad["heading_deg"] = 30.0;
  EXPECT_NE(invalid_argument_of([&] { parse_campaign(bad, "m.json"); }).find("heading_deg"),
            std::string::npos);
  bad["initial_attitude"] = "level+heading";
  EXPECT_EQ(invalid_argument_of([&] { parse_campaign(bad, "m.json"); }), "");
  // A sweep passes the keys on to its campaign (and leaves them out when not given).
  SweepConfig sweep = rich_pso_sweep();
  EXPECT_FALSE(sweep_campaign(sweep).to_json().contains("initial_attitude"));
  sweep.initial_attitude = InitialAttitudeMode::kLevelHeading;
  sweep.window_s = 10.0;
  EXPECT_EQ(sweep_campaign(sweep).to_json()["initial_attitude"], "level+heading");
  EXPECT_EQ(sweep_campaign(sweep).navigation_options().window_s, 10.0);
  bad = nlohmann::json::parse(kMemsConfig);
  bad["window_s"] = -1.0;
  EXPECT_NE(invalid_argument_of([&] { parse_campaign(bad, "m.json"); }).find("window_s = -1"),
            std::string::npos);
  // "heading_source" (level+heading's --heading-source): checked up front by the command line's
  // rules, recorded only when given; "measured" on data without heading.csv is refused by the
  // run with the command line's message.
  EXPECT_FALSE(old_style.to_json().contains("heading_source"));
  bad = nlohmann::json::parse(kMemsConfig);
  bad["heading_source"] = "measured";
  EXPECT_NE(invalid_argument_of([&] { parse_campaign(bad, "m.json"); })
                .find("m.json: heading_source measured: a heading source (--heading-source "
                      "measured) is only used by --initial-attitude level+heading"),
            std::string::npos);
  bad["initial_attitude"] = "level+heading";
  bad["heading_source"] = "compass";
  EXPECT_NE(invalid_argument_of([&] {
              parse_campaign(bad, "m.json");
            }).find("m.json: heading_source: --heading-source must be 'course'"),
            std::string::npos);
  bad["heading_source"] = "given";
  EXPECT_NE(invalid_argument_of([&] {
              parse_campaign(bad, "m.json");
            }).find("--heading-source given needs the heading"),
            std::string::npos);
  bad["heading_source"] = "measured";
  const CampaignConfig measured = parse_campaign(bad, "m.json");
  EXPECT_EQ(measured.to_json()["heading_source"], "measured");
  EXPECT_EQ(measured.navigation_options().initial_attitude.heading_source,
            HeadingSource::kMeasured);
  const fs::path dir2 = test::fresh_dir("mems-measured");
  options.out_dir = dir2.string();
  std::string no_heading;
  try {
    run_campaign(measured, options);
  } catch (const std::exception& e) {
    no_heading = e.what();
  }
  EXPECT_NE(no_heading.find("this dataset has no measured heading"), std::string::npos)
      << no_heading;
  fs::remove_all(dir2);
}

// GIVEN the MEMS campaign with "estimation_grade": "mems" and no "estimate" THEN it estimates
// the mems grade's default set (the four and gyro_bias_z at 0.1 deg/s and 10 mg), as identify
// --grade mems does; the resolved config, the manifest and every run file record the key; the
// scenarios' "grade" (the simulated noise) is a different key and stays as it was. Without the
// key the config resolves as before (no key, the catalogue's sigmas); a bad value is named. A
// sweep passes the key on.
TEST(Campaign, EstimationGradeSetsTheParametersAndIsRecorded) {
  nlohmann::json j = nlohmann::json::parse(kMemsConfig);
  j.erase("estimate");
  EXPECT_FALSE(parse_campaign(j, "m.json").to_json().contains("estimation_grade"));
  EXPECT_EQ(estimated_parameters(parse_campaign(j, "m.json")).size(), 4u);
  EXPECT_EQ(estimated_parameters(parse_campaign(j, "m.json"))[2].sigma, kSigmaGyroRadS);
  j["estimation_grade"] = "mems";
  j["initial_attitude"] = "level+heading";
  j["window_s"] = 10.0;
  const CampaignConfig mems = parse_campaign(j, "mems.json");
  const std::vector<EstimatedParameter> p = estimated_parameters(mems);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_EQ(p[4].name, "gyro_bias_z");
  EXPECT_NEAR(p[2].sigma, 0.1 * std::numbers::pi / 180.0, 1e-15);
  EXPECT_NEAR(p[0].sigma, 10e-3 * 9.80665, 1e-15);
  EXPECT_EQ(mems.to_json()["estimation_grade"], "mems");
  EXPECT_EQ(mems.to_json()["scenarios"][0]["grade"], "mems");  // the simulated noise, unchanged
  // Given estimate names take the grade's sigma too.
  nlohmann::json named = j;
  named["estimate"] = {"accel_bias_x", "gyro_bias_z:0.001"};
  const std::vector<EstimatedParameter> q = estimated_parameters(parse_campaign(named, "m.json"));
  ASSERT_EQ(q.size(), 2u);
  EXPECT_NEAR(q[0].sigma, 10e-3 * 9.80665, 1e-15);
  EXPECT_EQ(q[1].sigma, 0.001);
  const fs::path dir = test::fresh_dir("mems-grade");
  RunOptions options;
  options.out_dir = dir.string();
  options.quiet = true;
  ASSERT_TRUE(run_campaign(mems, options).complete);
  EXPECT_EQ(test::read_json(dir / "manifest.json")["config"]["estimation_grade"], "mems");
  EXPECT_EQ(test::read_json(dir / "manifest.json")["config"]["estimate"].size(), 5u);
  const nlohmann::json run = test::read_json(run_file(dir.string(), "rich-mems", "PSO", 1));
  EXPECT_EQ(run["estimation_grade"], "mems");
  ASSERT_EQ(run["parameters"].size(), 5u);
  EXPECT_EQ(run["parameters"][4]["name"], "gyro_bias_z");
  fs::remove_all(dir);

  nlohmann::json bad = j;
  bad["estimation_grade"] = "paper";  // a noise grade of the simulator, not an estimation grade
  EXPECT_NE(invalid_argument_of([&] {
              parse_campaign(bad, "m.json");
            }).find("estimation_grade 'paper': expected nav, tactical or mems"),
            std::string::npos);
  SweepConfig sweep = rich_pso_sweep();
  EXPECT_FALSE(sweep_campaign(sweep).to_json().contains("estimation_grade"));
  sweep.estimation_grade = "tactical";
  EXPECT_EQ(sweep_campaign(sweep).to_json()["estimation_grade"], "tactical");
  EXPECT_EQ(estimated_parameters(sweep_campaign(sweep)).size(), 5u);
}

}  // namespace
}  // namespace insid::campaign
