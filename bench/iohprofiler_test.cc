// IOHprofiler export (iohprofiler.h): the files parse back to the campaign's best-so-far curves,
// their lines follow IOHanalyzer's documented layout, and the reader reads the documented example.
#include "bench/iohprofiler.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "test_support/files.h"

namespace insid::campaign {
namespace {
namespace fs = std::filesystem;

const char* kConfig = R"({
  "name": "test-ioh",
  "scenarios": [{"name": "rich-short", "preset": "rich", "flight_s": 300, "grade": "nav",
                 "data_seed": 7},
                {"name": "rich-other", "preset": "rich", "flight_s": 300, "grade": "nav",
                 "data_seed": 9}],
  "algorithms": [{"label": "PSO", "name": "pso"},
                 {"label": "DVPIO", "name": "dvpio", "parameters": {"dist_threshold": 0.1}}],
  "seeds": [3, 1],
  "max_iterations": 6
})";

std::vector<std::string> lines_of(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(IohProfiler, ExportParsesBackToTheCampaignCurves) {
  // GIVEN a complete campaign of 2 scenarios x 2 algorithms x 2 seeds, exported
  const fs::path campaign = test::fresh_dir("campaign");
  const fs::path out = test::fresh_dir("out");
  const CampaignConfig config = parse_campaign(nlohmann::json::parse(kConfig), "test");
  RunOptions options;
  options.out_dir = campaign.string();
  options.threads = 2;
  options.quiet = true;
  ASSERT_TRUE(run_campaign(config, options).complete);
  const IohExportOutcome outcome = export_iohprofiler(campaign.string(), out.string());
  EXPECT_EQ(outcome.runs, 8);
  EXPECT_EQ(outcome.info_files, 4);
  EXPECT_EQ(outcome.missing_runs, 0);

  for (const char* label : {"PSO", "DVPIO"}) {
    for (int s = 0; s < 2; ++s) {
      const ScenarioSpec& scenario = config.scenarios[static_cast<std::size_t>(s)];
      const std::string fid = std::to_string(s + 1), inst = std::to_string(scenario.data_seed);
      const fs::path info_path = out / label / ("IOHprofiler_f" + fid + "_i" + inst + ".info");
      ASSERT_TRUE(fs::exists(info_path)) << info_path;
      // THEN the .info file reads back with the campaign's mapping
      const std::vector<IohInfoBlock> blocks = read_ioh_info(info_path.string());
      ASSERT_EQ(blocks.size(), 1u);
      const IohInfoBlock& info = blocks[0];
      EXPECT_EQ(info.value("funcId"), fid);
      EXPECT_EQ(info.value("funcName"), scenario.name);
      EXPECT_EQ(info.value("DIM"), "4");  // the paper's four estimated parameters
      EXPECT_EQ(info.value("algId"), label);
      EXPECT_EQ(info.value("maximization"), "F");
      EXPECT_EQ(info.value("algInfo").rfind(
                    std::string(label == std::string("PSO") ? "pso" : "dvpio"), 0),
                0u);
      EXPECT_EQ(info.data_file,
                "data_f" + fid + "/IOHprofiler_f" + fid + "_DIM4_i" + inst + ".dat");
      ASSERT_EQ(info.runs.size(), 2u);
      // AND the .dat blocks expand to the run files' best-so-far per evaluation, bit for bit
      const std::vector<IohDatRun> runs =
          read_ioh_dat((info_path.parent_path() / info.data_file).string());
      ASSERT_EQ(runs.size(), 2u);
      for (std::size_t r = 0; r < 2; ++r) {
        const nlohmann::json record =
            test::read_json(run_file(campaign.string(), scenario.name, label, config.seeds[r]));
        const auto trace = record["result"]["best_per_evaluation"].get<std::vector<double>>();
        EXPECT_EQ(expand_best_so_far(runs[r]), trace)
            << label << " " << scenario.name << " run " << r;
        EXPECT_EQ(info.runs[r].instance, inst);
        EXPECT_EQ(info.runs[r].evaluations, record["result"]["evaluations"].get<std::int64_t>());
        // The curves are the search fitness's (the config's "fitness"); the run's reported
        // fitness is the exact kernel's Eq. 15 of the same best point (issue 47).
        EXPECT_EQ(info.runs[r].best, trace.back());
        EXPECT_EQ(info.runs[r].best, record["search_fitness"]["best_f_search"].get<double>());
        EXPECT_NEAR(info.runs[r].best, record["result"]["fitness"].get<double>(),
                    1e-4 * info.runs[r].best);
        // Only the first evaluation, the improvements and the last one are recorded.
        std::size_t improvements = 0;
        for (std::size_t e = 1; e < trace.size(); ++e) improvements += trace[e] < trace[e - 1];
        EXPECT_LE(runs[r].size(), improvements + 2);
        EXPECT_GE(runs[r].size(), improvements + 1);
      }
      // AND every line has the documented layout (dataformat.md of IOHanalyzer)
      const std::vector<std::string> info_lines = lines_of(info_path);
      ASSERT_EQ(info_lines.size(), 3u);
      const std::regex header(
          R"(^suite = '[^',]*', funcId = \d+, funcName = '[^',]*', DIM = \d+, maximization = F, )"
          R"(algId = '[^',]*', algInfo = '[^',]*'$)");
      EXPECT_TRUE(std::regex_match(info_lines[0], header)) << info_lines[0];
      EXPECT_EQ(info_lines[1].rfind("% ", 0), 0u) << info_lines[1];
      const std::regex record(
          R"(^data_f\d+/IOHprofiler_f\d+_DIM\d+_i\d+\.dat(, \d+:\d+\|[-+0-9.e]+)+$)");
      EXPECT_TRUE(std::regex_match(info_lines[2], record)) << info_lines[2];
      for (const std::string& line : lines_of(info_path.parent_path() / info.data_file)) {
        if (line[0] == '"')
          EXPECT_EQ(line, "\"function evaluation\" \"best-so-far f(x)\"");
        else
          EXPECT_TRUE(std::regex_match(line, std::regex(R"(^\d+ [-+0-9.e]+$)"))) << line;
      }
    }
  }
  fs::remove_all(campaign);
  fs::remove_all(out);
}

TEST(IohProfiler, ReaderReadsTheDocumentedExampleLayout) {
  // The layout of IOHanalyzer's dataformat.md: a header of name = value pairs, a '%' line, the
  // data file with instance:running time|best-so-far per run; separation lines in the .dat.
  const fs::path dir = test::fresh_dir("example");
  fs::create_directories(dir / "data_f10");
  {
    std::ofstream info(dir / "IOHprofiler_f10_i1.info");
    info << "suite = 'PBO', funcId = 10, DIM = 625, algId = '(1+1) fGA'\n%\n"
            "data_f10/IOHprofiler_f10_DIM625.dat, 1:1953125|5.59000e+02, 1:1953125|5.54000e+02\n";
    std::ofstream dat(dir / "data_f10" / "IOHprofiler_f10_DIM625.dat");
    dat << "\"function evaluation\" \"best-so-far f(x)\"\n1 +2.95000e+02\n4 +2.90000e+02\n"
           "\"function evaluation\" \"best-so-far f(x)\"\n1 +3.20000e+02\n3 +3.20000e+02\n";
  }
  const std::vector<IohInfoBlock> blocks =
      read_ioh_info((dir / "IOHprofiler_f10_i1.info").string());
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].value("funcId"), "10");
  EXPECT_EQ(blocks[0].value("DIM"), "625");
  EXPECT_EQ(blocks[0].value("algId"), "(1+1) fGA");
  EXPECT_EQ(blocks[0].comment, "");
  ASSERT_EQ(blocks[0].runs.size(), 2u);
  EXPECT_EQ(blocks[0].runs[1].evaluations, 1953125);
  EXPECT_EQ(blocks[0].runs[1].best, 554.0);
  const std::vector<IohDatRun> runs =
      read_ioh_dat((dir / "data_f10" / "IOHprofiler_f10_DIM625.dat").string());
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(expand_best_so_far(runs[0]), (std::vector<double>{295, 295, 295, 290}));
  EXPECT_EQ(expand_best_so_far(runs[1]), (std::vector<double>{320, 320, 320}));

  // The reader is strict: a header without DIM, a record before any separation line, a best
  // that grows, are refused with the file and line.
  {
    std::ofstream info(dir / "bad.info");
    info << "funcId = 10, algId = 'x'\n%\ndata_f10/x.dat, 1:5|1\n";
    std::ofstream dat(dir / "bad.dat");
    dat << "1 +2.0\n";
    std::ofstream grows(dir / "grows.dat");
    grows << "\"function evaluation\" \"best-so-far f(x)\"\n1 2\n2 3\n";
  }
  EXPECT_THROW(read_ioh_info((dir / "bad.info").string()), std::runtime_error);
  EXPECT_THROW(read_ioh_dat((dir / "bad.dat").string()), std::runtime_error);
  try {
    read_ioh_dat((dir / "grows.dat").string());
    ADD_FAILURE() << "a growing best-so-far was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("grows.dat:3: best-so-far 3 larger"), std::string::npos)
        << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insid::campaign
