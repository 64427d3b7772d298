// The insid binary as a careless user meets it: a user directory as --out, a corrupted value in
// imu.csv, a compensation that blows the navigation up, an alignment window of zero. Each must
// end non-zero with the file, line or option named, and leave nothing half-written.
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support/files.h"
#include "test_support/process.h"

namespace {
namespace fs = std::filesystem;

namespace test = insid::test;
using insid::test::insid;
using insid::test::Outcome;

class CliSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = test::fresh_dir("cli-safety");
    fs::create_directories(root_);
    data_ = root_ / "data";
    const Outcome o = insid("simulate --preset straight --flight-s 20 --out " + data_.string());
    ASSERT_EQ(o.status, 0) << o.output;
  }
  void TearDown() override { fs::remove_all(root_); }

  // Replace line `line` (1-based) of `file` by `value`.
  static void set_line(const fs::path& file, int line, const std::string& value) {
    std::istringstream in(test::read_file(file));
    std::ostringstream out;
    std::string l;
    for (int k = 1; std::getline(in, l); ++k) out << (k == line ? value : l) << '\n';
    std::ofstream(file, std::ios::trunc) << out.str();
  }

  fs::path root_, data_;
};

TEST_F(CliSafety, SimulateIntoAUserDirectoryKeepsTheUsersFiles) {
  const fs::path proj = root_ / "proj";
  fs::create_directories(proj / "src");
  std::ofstream(proj / "src" / "code.c") << "int main;";
  const Outcome o = insid("simulate --preset straight --flight-s 5 --out " + proj.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("it holds 'src'"), std::string::npos) << o.output;
  EXPECT_EQ(test::read_file(proj / "src" / "code.c"), "int main;");
  EXPECT_FALSE(fs::exists(proj / "imu.csv"));
  const Outcome forced =
      insid("simulate --preset straight --flight-s 5 --force --out " + proj.string());
  EXPECT_EQ(forced.status, 0) << forced.output;
  EXPECT_EQ(test::read_file(proj / "src" / "code.c"), "int main;");
  EXPECT_TRUE(fs::exists(proj / "imu.csv"));
}

TEST_F(CliSafety, OneHugeImuValueIsAnErrorNamingFileAndLine) {
  const std::string clean = test::read_file(data_ / "imu.csv");
  for (const std::string value : {"1e300", "-9.8e15"}) {
    set_line(data_ / "imu.csv", 123, "1.22," + value + ",0,0,0,0,-0.0979");
    const fs::path summary = root_ / "s.json";
    const Outcome o = insid("navigate --data " + data_.string() + " --summary " + summary.string());
    EXPECT_NE(o.status, 0) << value;
    EXPECT_NE(o.output.find("imu.csv line 123, column dtheta_x_rad"), std::string::npos)
        << o.output;
    EXPECT_FALSE(fs::exists(summary));
    const Outcome id = insid("identify --algo pso --iterations 2 --data " + data_.string());
    EXPECT_NE(id.status, 0);
    EXPECT_NE(id.output.find("imu.csv line 123"), std::string::npos) << id.output;
    std::ofstream(data_ / "imu.csv", std::ios::trunc) << clean;
  }
}

TEST_F(CliSafety, NonFiniteNavigationIsAnErrorNamingTheCompensation) {
  const fs::path summary = root_ / "s.json";
  const fs::path nav = root_ / "nav.csv";
  const Outcome o =
      insid("navigate --data " + data_.string() + " --compensate accel_bias_x=1e30 --summary " +
            summary.string() + " --out " + nav.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find(
                "with --compensate accel_bias_x=1e+30, the navigation became non-finite at t = "),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("s (the step to imu.csv line "), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(summary));
  EXPECT_FALSE(fs::exists(nav));
  const Outcome align =
      insid("navigate --data " + data_.string() + " --compensate accel_bias_x=1e300");
  EXPECT_NE(align.status, 0);
  EXPECT_NE(align.output.find("alignment on imu.csv lines 2-"), std::string::npos) << align.output;
  EXPECT_NE(align.output.find("accel_bias_x=1e+300"), std::string::npos) << align.output;
}

TEST_F(CliSafety, ZeroAlignmentWindowWorksWithTruthAndIsNamedWithoutIt) {
  std::string meta = test::read_file(data_ / "meta.json");
  const auto at = meta.find("\"align_s\"");
  const auto colon = meta.find(':', at);
  const auto end = meta.find_first_of(",}", colon);
  std::ofstream(data_ / "meta.json", std::ios::trunc)
      << meta.substr(0, colon + 1) + " 0.004" + meta.substr(end);
  const Outcome without = insid("navigate --data " + data_.string());
  EXPECT_NE(without.status, 0);
  EXPECT_NE(without.output.find("align_s = 0.004 s"), std::string::npos) << without.output;
  const fs::path summary = root_ / "s.json";
  const Outcome truth = insid("navigate --data " + data_.string() +
                              " --initial-attitude truth --summary " + summary.string());
  EXPECT_EQ(truth.status, 0) << truth.output;
  EXPECT_NE(test::read_file(summary).find("\"fitness\": "), std::string::npos);
  EXPECT_EQ(test::read_file(summary).find("null"), std::string::npos) << test::read_file(summary);
}

// --initial-attitude: 'align' is gyrocompass and navigates exactly as the default; a
// bad mode or a heading without level+heading is named; MEMS data are refused for gyrocompassing
// (navigate and identify) with the expected sd, and level+heading records where the heading
// came from.
TEST_F(CliSafety, InitialAttitudeModesOnTheCommandLine) {
  const auto line_of = [](const std::string& json, const std::string& key) {
    const auto at = json.find("\"" + key + "\":");
    return at == std::string::npos ? std::string("(no " + key + ")")
                                   : json.substr(at, json.find('\n', at) - at);
  };
  const fs::path s_default = root_ / "default.json", s_align = root_ / "align.json";
  ASSERT_EQ(insid("navigate --data " + data_.string() + " --summary " + s_default.string()).status,
            0);
  const Outcome align = insid("navigate --data " + data_.string() +
                              " --initial-attitude align --summary " + s_align.string());
  ASSERT_EQ(align.status, 0) << align.output;
  EXPECT_EQ(line_of(test::read_file(s_align), "fitness"),
            line_of(test::read_file(s_default), "fitness"));
  EXPECT_NE(test::read_file(s_align).find("\"initial_attitude\": \"gyrocompass\""),
            std::string::npos);
  EXPECT_NE(test::read_file(s_align).find("\"gyrocompass_heading_sd_deg\""), std::string::npos);
  const Outcome bad = insid("navigate --data " + data_.string() + " --initial-attitude compass");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("--initial-attitude must be"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("got 'compass'"), std::string::npos) << bad.output;
  const Outcome stray = insid("navigate --data " + data_.string() + " --heading-deg 10");
  EXPECT_NE(stray.status, 0);
  EXPECT_NE(stray.output.find("only used by --initial-attitude level+heading"), std::string::npos)
      << stray.output;

  const fs::path mems = root_ / "mems";
  ASSERT_EQ(
      insid("simulate --preset straight --grade mems --flight-s 60 --out " + mems.string()).status,
      0);
  // sqrt((0.2 deg/sqrt(h))^2 / 600 s + b^2) / (15.04 deg/h cos 40.068 deg): b the catalogue
  // sigma (navigate) or identify's default box edge, 4 sigma of the data's grade (MEMS here:
  // 4 x 0.1 deg/s = 1440 deg/h, identification/grade.h).
  const std::vector<std::pair<std::string, std::string>> refusals = {
      {"navigate",
       "heading sd 2.44 deg (angle random walk 0.2 deg/sqrt(h) declared in meta.json "
       "noise.arw_deg_rth, averaged over the 600 s static window; gyro bias allowance "
       "0.01 deg/h"},
      {"identify --algo lm --iterations 1",
       "heading sd 7.17e+03 deg (angle random walk 0.2 "
       "deg/sqrt(h) declared in meta.json noise.arw_deg_rth, averaged over the 600 s "
       "static window; gyro bias allowance 1.44e+03 deg/h"}};
  for (const auto& [command, expected] : refusals) {
    const Outcome refused = insid(command + " --data " + mems.string());
    EXPECT_NE(refused.status, 0) << command;
    EXPECT_NE(refused.output.find("--initial-attitude gyrocompass refused: expected gyrocompass " +
                                  expected),
              std::string::npos)
        << refused.output;
  }
  const fs::path s_given = root_ / "given.json", s_course = root_ / "course.json";
  const Outcome given =
      insid("navigate --data " + mems.string() +
            " --initial-attitude level+heading --heading-deg 0 --summary " + s_given.string());
  ASSERT_EQ(given.status, 0) << given.output;
  EXPECT_NE(test::read_file(s_given).find("\"heading_source\": \"given\""), std::string::npos)
      << test::read_file(s_given);
  const Outcome course = insid("navigate --data " + mems.string() +
                               " --initial-attitude level+heading --summary " + s_course.string());
  ASSERT_EQ(course.status, 0) << course.output;
  EXPECT_NE(test::read_file(s_course).find("\"heading_source\": \"gnss_course\""),
            std::string::npos);
  EXPECT_NE(test::read_file(s_course).find("\"course_t_s\": "), std::string::npos);
}

// The command-line and config battery: every bad value is refused before any work, with a
// non-zero exit and a message naming the option (or config key) and the value.
struct BadInput {
  std::string args;                   // after "insid"
  std::vector<std::string> expected;  // substrings of the output
  bool parse_error = false;           // refused by the parser (exit 2), else after it (exit 1)
};

std::vector<BadInput> option_cases(const std::string& data) {
  std::vector<BadInput> cases;
  // Every numeric option of every subcommand, with values of the wrong kind or range.
  struct Option {
    std::string command, option;
    std::vector<std::string> bad;
  };
  const std::vector<std::string> counts = {"-1", "nan", "abc", "1.5", "1e999"};
  const std::vector<std::string> seconds = {"-5", "0", "nan", "inf", "abc", "1e9"};
  const std::vector<std::string> seeds = {"-1", "18446744073709551616", "1.5", "abc", "+3", "0x10"};
  const std::string sim = "simulate --preset straight --out " + data + "-never";
  const std::string bench = "bench --preset quick --out " + data + "-never";
  const std::string sweep = "sweep --algo pio --grid R=0.1:0.3:3 --out " + data + "-never";
  const std::string ident = "identify --algo pso --data " + data;
  const std::string diag = "diagnose --data " + data;
  const std::vector<Option> options = {
      {sim, "--flight-s", seconds},
      {sim, "--seed", seeds},
      {bench, "--seeds", {"0", "-1", "1000000000", "abc", "2.5"}},
      {bench, "--threads", {"-1", "5000", "abc"}},
      {bench, "--flight-s", seconds},
      {bench, "--max-new-runs", {"-1", "0", "abc"}},
      {sweep, "--random", {"0", "-1", "abc"}},
      {sweep, "--seeds", {"0", "-3", "1000000000"}},
      {sweep, "--iterations", counts},
      {sweep, "--evaluations", counts},
      {sweep, "--threads", {"-1", "abc"}},
      {sweep, "--flight-s", seconds},
      {ident, "--seed", seeds},
      {ident, "--iterations", counts},
      {ident, "--evaluations", counts},
      {ident, "--threads", {"-1", "nan"}},
      {diag, "--seed", seeds},
      {diag, "--max-effects", {"0", "-1", "abc"}},
      {diag, "--iterations", {"0", "-1"}},
      {diag, "--replicas-basis", {"1", "-1", "abc"}},
      {diag, "--replicas-calibration", {"0", "abc"}},
      {diag, "--alpha", {"nan", "0", "0.9", "abc"}},
      {diag, "--observable-max-sigma", {"nan", "-1", "inf"}},
      {diag, "--threads", {"-1", "abc"}},
      {"navigate --data " + data, "--window-s", {"-1", "nan", "inf", "abc"}},
      {ident, "--window-s", {"-1", "nan", "abc"}},
      {diag, "--window-s", {"-2", "inf"}}};
  for (const Option& o : options)
    for (const std::string& value : o.bad)
      cases.push_back({o.command + " " + o.option + " " + value, {o.option, value}, true});
  // Values inside --param, --grid, --set, --compensate.
  cases.push_back({ident + " --param population=1e9", {"population", "1e+09", "limit"}, true});
  cases.push_back({ident + " --param population=2.5", {"population", "integer"}, true});
  cases.push_back({ident + " --param nosuch=1", {"nosuch", "valid parameters"}, true});
  cases.push_back({sweep + " --grid R=0.1:0.2:2", {"--grid", "'R'", "twice"}, true});
  cases.push_back({sim + " --set gyro_bias_x=abc", {"--set", "gyro_bias_x"}, true});
  cases.push_back({sim + " --set nosuch=1", {"nosuch"}, true});
  // A heading option without --heading was accepted (and nan with it) and ignored.
  cases.push_back(
      {sim + " --heading-rate-hz nan", {"--heading-rate-hz", "requires --heading"}, true});
  cases.push_back({"navigate --data " + data + " --compensate accel_bias_x",
                   {"--compensate", "NAME=VALUE"},
                   true});
  // Values checked after parsing (every command's options), named: a value the
  // command line got wrong is a usage error wherever the command reads it (the
  // README's table): exit 2.
  cases.push_back({ident + " --estimate gyro_bias_x:0",
                   {"--estimate 'gyro_bias_x:0'", "SIGMA must be > 0"},
                   true});
  cases.push_back({ident + " --estimate gyro_bias_x:-1e-7", {"SIGMA must be > 0"}, true});
  cases.push_back({ident + " --estimate gyro_bias_x:1e-7:1:-1", {"LO must be < HI"}, true});
  cases.push_back({ident + " --param population=0", {"population", "got 0"}, true});
  cases.push_back({ident + " --param population=-3", {"population", "got -3"}, true});
  cases.push_back({"identify --algo nosuch --data " + data, {"unknown optimizer 'nosuch'"}, true});
  cases.push_back({"navigate --data " + data + " --alignment sideways", {"got 'sideways'"}, true});
  cases.push_back({sweep + " --grid R=0.1:0.3:0", {"--grid 'R=0.1:0.3:0'", "N must be"}, true});
  cases.push_back({sweep + " --grid R=0.3:0.1:3", {"LO must be <= HI"}, true});
  cases.push_back({sweep + " --grid R=", {"--grid", "got 'R='"}, true});
  cases.push_back({sweep + " --preset nosuch", {"unknown preset 'nosuch'"}, true});
  cases.push_back({sweep + " --grade bogus", {"unknown noise grade 'bogus'"}, true});
  cases.push_back({"bench --preset nosuch --out " + data + "-never",
                   {"unknown campaign preset 'nosuch'"},
                   true});
  cases.push_back({sim + " --set gyro_bias_x=nan", {"--set gyro_bias_x", "'nan'"}, true});
  cases.push_back({diag + " --candidates nosuch", {"unknown effect name 'nosuch'"}, true});
  cases.push_back({diag + " --base gyro_bias_x:0", {"SIGMA must be > 0"}, true});
  // A window shorter than one GNSS period (10 Hz here) is refused by the problem, named.
  cases.push_back({"navigate --data " + data + " --window-s 0.05",
                   {"window_s = 0.05 s is shorter than one GNSS period (0.1 s"}});
  return cases;
}

// Campaign configs with a wrong type, value or name: (config text, expected substrings).
std::vector<std::pair<std::string, std::vector<std::string>>> config_cases() {
  const std::string scenario = R"({"name": "s", "preset": "rich", "flight_s": 60})";
  const std::string algo = R"({"label": "P", "name": "pso"})";
  auto config = [&](const std::string& scenarios, const std::string& algorithms,
                    const std::string& rest) {
    return "{\"scenarios\": " + scenarios + ", \"algorithms\": " + algorithms +
           ", \"max_iterations\": 2" + rest + "}";
  };
  const std::string s1 = "[" + scenario + "]", a1 = "[" + algo + "]";
  std::string many_scenarios = "[", many_algorithms = "[";
  for (int k = 0; k < 30; ++k) {
    many_scenarios += std::string(k ? ", " : "") + R"({"name": "s)" + std::to_string(k) +
                      R"(", "preset": "rich", "flight_s": 60})";
    many_algorithms +=
        std::string(k ? ", " : "") + R"({"label": "P)" + std::to_string(k) + R"(", "name": "pso"})";
  }
  many_scenarios += "]";
  many_algorithms += "]";
  return {
      {config(s1, "\"pso\"", ""), {"algorithms: expected an array, found a string \"pso\""}},
      {config("\"rich\"", a1, ""), {"scenarios: expected an array, found a string \"rich\""}},
      {config(s1, a1, R"(, "seeds": [1, "two", 3])"),
       {"seeds[1]: expected a whole number in [0, 1000000000], found a string \"two\""}},
      {config(s1, a1, R"(, "seeds": [1, 1, 2])"), {"seed 1", "twice"}},
      {config(s1, a1, R"(, "seeds": [1.5])"),
       {"seeds[0]: expected a whole number", "found a number 1.5"}},
      {config(s1, a1, R"(, "seeds": [-1])"),
       {"seeds[0]: expected a whole number", "found a number -1"}},
      {config(s1, a1, R"(, "seeds": 1000000000)"), {"seeds", "limit"}},
      {config(s1, a1, R"(, "seeds": 0)"), {"no seed"}},
      {config(s1, a1, R"(, "seeds": "31")"),
       {"seeds: expected a count or a list of seeds, found a string \"31\""}},
      {config(s1, a1, R"(, "estimate": [3])"),
       {"estimate[0]: expected a string, found a number 3"}},
      {config(s1, a1, R"(, "estimate": "gyro_bias_x")"),
       {"estimate: expected an array, found a string"}},
      {config(s1, a1, R"(, "target_error_sigma": ["a"])"),
       {"target_error_sigma[0]: expected a finite number, found a string \"a\""}},
      {config(s1, a1, R"(, "max_evaluations": -5)"), {"max_evaluations"}},
      {config(s1, a1, R"(, "nosuch": 1)"), {"nosuch: unknown key (valid keys: name, scenarios, "}},
      {config(s1, a1, R"(, "alignment": "sideways")"), {"sideways"}},
      {config(R"([{"name": "../../escape_scn", "preset": "rich"}])", a1, ""),
       {"scenario name '../../escape_scn'"}},
      {config(R"([{"name": "", "preset": "rich"}])", a1, ""), {"scenario name ''"}},
      {config(R"([{"name": "a b", "preset": "rich"}])", a1, ""), {"scenario name 'a b'"}},
      {config(s1, R"([{"label": "..", "name": "pso"}])", ""), {"algorithm label '..'"}},
      {config(s1, R"([{"label": "x/y", "name": "pso"}])", ""), {"algorithm label 'x/y'"}},
      {config(s1, R"([{"name": "nosuch"}])", ""), {"nosuch"}},
      {config(s1, R"([{"name": "pso", "parameters": {"w": "high"}}])", ""),
       {"algorithms[0].parameters.w: expected a number, found a string \"high\""}},
      {config(s1, R"([{"name": "pso", "parameters": {"population": 1e9}}])", ""),
       {"population", "limit"}},
      {config(s1, R"([{"name": "pso"}, {"name": "pso"}])", ""), {"label 'pso' used twice"}},
      {config(R"([{"name": "s", "preset": "rich"}, {"name": "s", "preset": "paper"}])", a1, ""),
       {"scenario name 's' used twice"}},
      {config(R"([{"name": "s"}])", a1, ""), {"exactly one of \"preset\" and \"data\""}},
      {config(R"([{"name": "s", "preset": "rich", "flight_s": "long"}])", a1, ""),
       {"scenarios[0].flight_s: expected a number, found a string \"long\""}},
      {config(R"([{"name": "s", "preset": "rich", "data_seed": 1.5}])", a1, ""),
       {"scenarios[0].data_seed: expected a whole number"}},
      {config(R"([{"name": "s", "preset": "rich", "set": {"gyro_bias_x": "big"}}])", a1, ""),
       {"scenarios[0].set.gyro_bias_x: expected a number, found a string \"big\""}},
      {config(R"([{"name": "s", "preset": "rich", "set": {"nosuch": 1}}])", a1, ""),
       {"scenarios[0].set.nosuch: unknown effect name 'nosuch'"}},
      {"[1, 2]", {"expected an object, found an array [1,2]"}},
      {"{\"scenarios\": [", {"not valid JSON"}},
      // 30 x 30 x 100000 = 90 million runs, refused at once with the count.
      {config(many_scenarios, many_algorithms, R"(, "seeds": 100000)"),
       {"90000000 runs (30 scenarios x 30 algorithms x 100000 seeds)", "limit"}},
  };
}

TEST_F(CliSafety, EveryBadOptionOrConfigValueIsRefusedUpFrontAndNamed) {
  const std::vector<BadInput> options = option_cases(data_.string());
  const auto configs = config_cases();
  int refused = 0;
  for (const BadInput& c : options) {
    const Outcome o = insid(c.args);
    EXPECT_NE(o.status, 0) << c.args << "\n" << o.output;
    // A value the parser refuses is a usage error (2); one refused after parsing, a failure (1).
    EXPECT_EQ(o.status, c.parse_error ? 2 : 1) << c.args << "\n" << o.output;
    refused += o.status != 0;
    for (const std::string& part : c.expected)
      EXPECT_NE(o.output.find(part), std::string::npos)
          << c.args << ": output lacks '" << part << "':\n"
          << o.output;
  }
  for (std::size_t k = 0; k < configs.size(); ++k) {
    const fs::path file = root_ / ("config" + std::to_string(k) + ".json");
    std::ofstream(file) << configs[k].first;
    const fs::path out = root_ / ("campaign" + std::to_string(k));
    const Outcome o = insid("bench --config " + file.string() + " --out " + out.string());
    EXPECT_NE(o.status, 0) << configs[k].first << "\n" << o.output;
    EXPECT_EQ(o.status, 1) << configs[k].first << "\n" << o.output;
    EXPECT_EQ(o.output.rfind("insid bench: error: ", 0), 0u) << o.output;
    refused += o.status != 0;
    for (const std::string& part : configs[k].second)
      EXPECT_NE(o.output.find(part), std::string::npos)
          << configs[k].first << ": output lacks '" << part << "':\n"
          << o.output;
    EXPECT_FALSE(fs::exists(out)) << configs[k].first << ": wrote " << out;
  }
  EXPECT_FALSE(fs::exists(data_.string() + "-never"));
  std::printf("[ measured ] %d of %zu bad command lines and configs refused\n", refused,
              options.size() + configs.size());
}

// --window-s is recorded in navigate's summary and identify's result.
TEST_F(CliSafety, WindowLengthIsRecordedInEveryResult) {
  const fs::path summary = root_ / "s.json", result = root_ / "r.json";
  Outcome o =
      insid("navigate --data " + data_.string() + " --window-s 5 --summary " + summary.string());
  ASSERT_EQ(o.status, 0) << o.output;
  // 20 s flight after the 600 s alignment: restarts at 605, 610, 615 s.
  EXPECT_NE(test::read_file(summary).find("\"window_s\": 5.0"), std::string::npos)
      << test::read_file(summary);
  EXPECT_NE(test::read_file(summary).find("\"windows\": 4"), std::string::npos)
      << test::read_file(summary);
  o = insid("navigate --data " + data_.string() + " --summary " + summary.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(test::read_file(summary).find("\"window_s\": 0.0"), std::string::npos)
      << test::read_file(summary);
  EXPECT_NE(test::read_file(summary).find("\"windows\": 1"), std::string::npos)
      << test::read_file(summary);
  o = insid("identify --algo pso --iterations 1 --no-reference-optimum --data " + data_.string() +
            " --window-s 5 --out " + result.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(test::read_file(result).find("\"window_s\": 5.0"), std::string::npos);
}

// import/export: an export -> import round trip through the binary; a user directory as --out
// is refused and kept; bad specs and files are named; a failed import writes nothing.
TEST_F(CliSafety, ImportAndExportRefuseBadInputAndNeverHalfWrite) {
  const fs::path kf = root_ / "kf", back = root_ / "back";
  Outcome o = insid("export --to kf-gins --data " + data_.string() + " --out " + kf.string());
  ASSERT_EQ(o.status, 0) << o.output;
  o = insid("import kf-gins --imu " + (kf / "imu.txt").string() + " --gnss " +
            (kf / "gnss.txt").string() +
            " --align-s 600 --static-rate 5 --static-accel-sd 0.3 --out " + back.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(test::read_file(back / "meta.json").find("insid-dataset/2"), std::string::npos);
  EXPECT_NE(test::read_file(back / "provenance.json").find("\"sha256\""), std::string::npos);
  // The shared import options (import/import_recording.h, ImportAssembly::record) are recorded.
  EXPECT_NE(test::read_file(back / "provenance.json").find("\"static_rate_dps\": 5.0"),
            std::string::npos);
  EXPECT_NE(test::read_file(back / "provenance.json").find("\"static_accel_sd_mps2\": 0.3"),
            std::string::npos);
  o = insid("navigate --data " + back.string() + " --summary " + (root_ / "s.json").string() +
            " --out " + (root_ / "n.csv").string());
  EXPECT_EQ(o.status, 0) << o.output;
  // A UTF-8 byte-order mark at the start of a text log is skipped: every row is kept (the
  // first data row is not taken for a header and dropped silently).
  for (const char* name : {"imu.txt", "gnss.txt"})
    std::ofstream(root_ / ("bom-" + std::string(name)))
        << "\xEF\xBB\xBF" << test::read_file(kf / name);
  const fs::path bom = root_ / "bom";
  o = insid("import kf-gins --imu " + (root_ / "bom-imu.txt").string() + " --gnss " +
            (root_ / "bom-gnss.txt").string() +
            " --align-s 600 --static-rate 5 --static-accel-sd 0.3 --out " + bom.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(test::read_file(bom / "imu.csv"), test::read_file(back / "imu.csv"));
  EXPECT_EQ(test::read_file(bom / "gnss.csv"), test::read_file(back / "gnss.csv"));

  // A user directory as --out: refused, kept.
  const fs::path proj = root_ / "proj";
  fs::create_directories(proj);
  std::ofstream(proj / "notes.txt") << "mine";
  o = insid("import kf-gins --imu " + (kf / "imu.txt").string() + " --gnss " +
            (kf / "gnss.txt").string() + " --out " + proj.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("it holds 'notes.txt'"), std::string::npos) << o.output;
  o = insid("export --to kf-gins --data " + data_.string() + " --out " + proj.string());
  EXPECT_NE(o.status, 0);
  EXPECT_EQ(test::read_file(proj / "notes.txt"), "mine");
  EXPECT_FALSE(fs::exists(proj / "imu.txt"));

  // Bad spec values and files: named, nothing written.
  const fs::path out = root_ / "never";
  o = insid("import csv --imu " + (kf / "imu.txt").string() +
            " --columns t,ax,ay,az,gx,gy,gq --units s,g,rad/s --gnss " +
            (kf / "gnss.txt").string() + " --out " + out.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("--columns: unknown role 'gq'"), std::string::npos) << o.output;
  o = insid("import csv --imu " + (kf / "imu.txt").string() +
            " --columns t,ax,ay,az,gx,gy,gz --units s,furlong,rad/s --gnss " +
            (kf / "gnss.txt").string() + " --out " + out.string());
  EXPECT_NE(o.output.find("accelerometer unit 'furlong'"), std::string::npos) << o.output;
  o = insid("import kf-gins --imu " + (kf / "gnss.txt").string() + " --gnss " +
            (kf / "gnss.txt").string() + " --out " + out.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("gnss.txt line 1: 13 fields, expected 7 or 8"), std::string::npos)
      << o.output;
  // GNSS of another week than the IMU: no overlap, named.
  std::string shifted;
  {
    std::istringstream in(test::read_file(kf / "gnss.txt"));
    std::string line;
    while (std::getline(in, line)) {
      const auto space = line.find(' ');
      shifted +=
          std::to_string(std::stod(line.substr(0, space)) + 5000.0) + line.substr(space) + "\n";
    }
  }
  std::ofstream(root_ / "late.txt") << shifted;
  o = insid("import kf-gins --imu " + (kf / "imu.txt").string() + " --gnss " +
            (root_ / "late.txt").string() + " --out " + out.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("does not overlap the IMU data"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace

namespace manners {  // Command-line manners

namespace test = insid::test;
using insid::test::insid;
using insid::test::Outcome;

// `insid --version` prints the git revision the binary was built from (and exits 0).
// Inputs are checked before they are read whole. A 3 GiB log of garbage cost
// 3 GiB of memory (or a bare std::bad_alloc) before its format was looked at; now its magic is
// read first, and any input over --max-input-mb is refused by its size.
TEST_F(CliSafety, HugeInputsAreRefusedBeforeTheyAreReadNamingFileAndLimit) {
  // GIVEN sparse files (no disk, no memory until read): 3 GiB of zeros as logs, 5 GiB as text
  const fs::path big_log = root_ / "huge.ulg", big_bin = root_ / "huge.bin";
  const fs::path big_text = root_ / "huge.txt", two_mb = root_ / "two_mb.txt";
  for (const fs::path& p : {big_log, big_bin, big_text, two_mb}) std::ofstream(p).close();
  fs::resize_file(big_log, 3ull << 30);
  fs::resize_file(big_bin, 3ull << 30);
  fs::resize_file(big_text, 5ull << 30);
  fs::resize_file(two_mb, 2ull << 20);
  const fs::path out = root_ / "never";
  // WHEN each is imported THEN it is refused by its magic or size, naming the file (and the
  // option that lifts the limit), and nothing is written
  Outcome o = insid("import ulog " + big_log.string() + " --out " + out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "LOG " + big_log.string() + ": not a PX4 ULog")) << o.output;
  o = insid("import ardupilot " + big_bin.string() + " --out " + out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(
      test::contains(o.output, "LOG " + big_bin.string() + ": not an ArduPilot DataFlash log"))
      << o.output;
  o = insid("import kf-gins --imu " + big_text.string() + " --gnss " + big_text.string() +
            " --out " + out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, big_text.string() +
                                           ": 5120 MiB (5368709120 bytes), over the limit "
                                           "of 4096 MiB; raise it with --max-input-mb"))
      << o.output;
  o = insid("import kf-gins --imu " + two_mb.string() + " --gnss " + two_mb.string() +
            " --max-input-mb 1 --out " + out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "over the limit of 1 MiB; raise it with --max-input-mb"))
      << o.output;
  // 2 GiB of zeros given as the IMU CSV (under the size limit) is not text: refused on
  // its first bytes (it took 45-53 s and 6-8 GB before "out of memory").
  const fs::path zeros = root_ / "zeros.csv";
  std::ofstream(zeros).close();
  fs::resize_file(zeros, 2ull << 30);
  const fs::path gnss_text = root_ / "gnss.txt";
  std::ofstream(gnss_text) << "345600.0 40.0 116.0 50.0 0.01 0.01 0.02\n"
                              "345601.0 40.0 116.0 50.0 0.01 0.01 0.02\n"
                              "345602.0 40.0 116.0 50.0 0.01 0.01 0.02\n";
  o = insid("import kf-gins --imu " + zeros.string() + " --gnss " + gnss_text.string() + " --out " +
            out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, zeros.string() + ": not a text file: byte 0 is a NUL byte"))
      << o.output;
  EXPECT_FALSE(fs::exists(out));
  // AND no child read them: the largest resident set of the commands stays far below 1 GiB
  // (measured, not timed: the old reader held the whole 3 GiB)
  struct rusage usage {};
  ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &usage), 0);
  EXPECT_LT(usage.ru_maxrss, 256 * 1024) << "KiB";  // ru_maxrss is in KiB on Linux
  std::cout << "largest resident set of the refused imports: " << usage.ru_maxrss / 1024
            << " MiB\n";
}

TEST(CliManners, VersionPrintsTheGitRevision) {
  const std::string revision = INSID_GIT_REVISION;
  ASSERT_NE(revision, "unknown") << "configured outside a git checkout";
  const Outcome o = insid("--version");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(test::contains(o.output, "git revision: " + revision)) << o.output;
  EXPECT_TRUE(test::contains(o.output, "build type:")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "compiler:")) << o.output;
}

// The three documented exit codes, each with the one error prefix; the table is in --help.
TEST_F(CliSafety, ExitCodesAreTheDocumentedOnesWithOneErrorPrefix) {
  const Outcome help = insid("--help");
  EXPECT_EQ(help.status, 0);
  for (const std::string line : {"Exit codes:", "  0  done", "  1  the command ran and failed",
                                 "  2  the command line was refused"})
    EXPECT_TRUE(test::contains(help.output, line)) << help.output;

  const std::string d = data_.string(), never = (root_ / "never").string();
  struct Case {
    std::string args, prefix;
    int status;
  };
  const std::vector<Case> cases = {
      {"", "insid: error: A subcommand is required", 2},
      {"nosuch", "insid: error: unknown command 'nosuch'; the commands are navigate identify", 2},
      {"navigate", "insid navigate: error: --data is required", 2},
      {"navigate --data " + d + " --nosuch 1", "insid navigate: error: The following argument", 2},
      {"bench --preset quick --seeds 0 --out " + never, "insid bench: error: --seeds: value 0", 2},
      {"identify --data " + d + " --quiet --verbose",
       "insid identify: error: --quiet excludes --verbose", 2},
      {"simulate --out " + never, "insid simulate: error: give exactly one of --preset", 2},
      {"simulate --preset straight", "insid simulate: error: --out DIR is required", 2},
      {"identify --data " + d + " --uncertainty-replicas 5",
       "insid identify: error: --uncertainty-replicas 5", 2},
      {"import csv --imu x --columns t,ax,ay,az,gx,gy,gz --units s,g,rad/s --gnss y --imu-time "
       "relative --out " +
           never,
       "insid import csv: error: --imu-time relative needs --imu-time-offset-s", 2},
      // Values the command line got wrong, wherever the command reads them.
      {"identify --data " + d + " --estimate gyro_bias_x:0", "insid identify: error: ", 2},
      {"identify --data " + d + " --estimate gyro_bias_x:1e-5:2:1", "insid identify: error: ", 2},
      {"identify --data " + d + " --param bogus=1", "insid identify: error: ", 2},
      {"identify --data " + d + " --algo nonexistent", "insid identify: error: --algo", 2},
      {"identify --data " + d + " --iterations 0 --evaluations 0", "insid identify: error: ", 2},
      {"simulate --preset nope --out " + never, "insid simulate: error: --preset", 2},
      {"import csv --imu x --gnss y --columns t,ax,ay,az,gx,gy,gz --units s,g,rad/s "
       "--mounting-rpy-deg nan,0,0 --out " +
           never,
       "insid import csv: error: ", 2},
      {"import csv --imu x --gnss y --columns t,t,ay,az,gx,gy,gz --units s,g,rad/s --out " + never,
       "insid import csv: error: --columns", 2},
      {"import csv --imu x --gnss y --columns t,ax,ay,az,gx,gy,gz --units s,furlong,rad/s --out " +
           never,
       "insid import csv: error: --units", 2},
      {"bench --preset quick --shard 3/2 --out " + never, "insid bench: error: --shard", 2},
      {"bench --preset quick --shard 1/2 --force-new --out " + never, "insid bench: error: ", 2},
      {"bench --preset quick --out ''", "insid bench: error: ", 2},
      // Conflicting options are usage errors (exit 2), as the README says.
      {"navigate --data " + d + " --initial-attitude given --heading-deg 30",
       "insid navigate: error: --initial-attitude: a heading", 2},
      {"export --to iohprofiler --out " + never, "insid export: error: --to iohprofiler needs", 2},
      {"diagnose --data " + d + " --base gyro_bias_x --candidates gyro_bias_x",
       "insid diagnose: error: --candidates gyro_bias_x is also in --base", 2},
      {"sweep --algo pio --grid R=0.1:0.3:3 --preset rich --data " + d + " --out " + never,
       "insid sweep: error: ", 2},
      {"navigate --data " + never, "insid navigate: error: dataset directory", 1},
      {"navigate --data " + d + " --compensate-from " + (data_ / "meta.json").string(),
       "insid navigate: error: --compensate-from " + (data_ / "meta.json").string() +
           ": not an identify result",
       1},
      {"navigate --data " + d + " --summary " + (root_ / "ok.json").string(), "", 0},
  };
  for (const Case& c : cases) {
    const Outcome o = insid(c.args);
    EXPECT_EQ(o.status, c.status) << "insid " << c.args << "\n" << o.output;
    if (!c.prefix.empty()) {
      EXPECT_EQ(o.output.rfind(c.prefix, 0), 0u) << "insid " << c.args << "\n" << o.output;
    }
    if (c.status == 2) {
      EXPECT_TRUE(test::contains(o.output, "--help' for the options")) << o.output;
    }
  }
  EXPECT_FALSE(fs::exists(never));
}

// Progress to a file or pipe: plain lines, never '\r'; nothing with --quiet; the closing line
// gives the iterations actually done; a sweep's progress is labelled "insid sweep".
TEST_F(CliSafety, ProgressToANonTerminalHasNoCarriageReturn) {
  const std::string d = data_.string();
  const fs::path result = root_ / "r.json";
  const std::string ident =
      "identify --algo pso --iterations 3 --no-reference-optimum "
      "--uncertainty-replicas 0 --data " +
      d + " --out " + result.string();
  const Outcome o = insid(ident);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_FALSE(test::contains(o.output, "\r")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "insid identify: pso iteration 1/3")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "insid identify: pso stopped after 3 iteration(s)"))
      << o.output;
  const Outcome quiet = insid(ident + " --quiet");
  ASSERT_EQ(quiet.status, 0) << quiet.output;
  EXPECT_EQ(quiet.output, "");
  // lm converges, then restarts until the budget is spent: the closing line says where the
  // best was first reached, not only the budget.
  const Outcome lm = insid(
      "identify --algo lm --iterations 12 --no-reference-optimum "
      "--uncertainty-replicas 0 --data " +
      d + " --out " + result.string());
  ASSERT_EQ(lm.status, 0) << lm.output;
  EXPECT_TRUE(test::contains(lm.output, "insid identify: lm stopped after ")) << lm.output;
  EXPECT_TRUE(test::contains(lm.output, " first reached at iteration ")) << lm.output;

  const fs::path sweep = root_ / "sweep";
  const Outcome s = insid(
      "sweep --algo pso --grid w=0.5,0.7 --seeds 1 --iterations 2 --preset "
      "straight --flight-s 20 --out " +
      sweep.string());
  ASSERT_EQ(s.status, 0) << s.output;
  EXPECT_FALSE(test::contains(s.output, "\r")) << s.output;
  EXPECT_FALSE(test::contains(s.output, "insid bench")) << s.output;
  EXPECT_TRUE(test::contains(s.output, "insid sweep: runs 2/2")) << s.output;
  const Outcome sim =
      insid("simulate --preset straight --flight-s 5 --quiet --out " + (root_ / "q").string());
  ASSERT_EQ(sim.status, 0) << sim.output;
  EXPECT_EQ(sim.output, "");
}

// bench --round-log writes a new file only (a mistyped name must not replace a user's file), one
// JSON line per lock-step round, whose candidates add up to the run files' evaluations.
TEST_F(CliSafety, BenchRoundLogIsANewFileWithEveryRound) {
  const fs::path log = root_ / "rounds.jsonl";
  const fs::path out = root_ / "campaign";
  std::ofstream(log) << "the user's notes\n";
  const std::string bench =
      "bench --preset quick --seeds 1 --flight-s 20 --threads 2 --quiet --out ";
  const Outcome refused = insid(bench + out.string() + " --round-log " + log.string());
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_TRUE(test::contains(refused.output, "--round-log " + log.string() + ": the file exists"))
      << refused.output;
  EXPECT_EQ(test::read_file(log), "the user's notes\n");
  EXPECT_FALSE(fs::exists(out));
  // AND a campaign refused before its first round (--out holds a user's file) leaves no log
  fs::remove(log);
  const fs::path user_dir = root_ / "user";
  fs::create_directories(user_dir);
  std::ofstream(user_dir / "notes.txt") << "mine\n";
  const Outcome foreign = insid(bench + user_dir.string() + " --round-log " + log.string());
  EXPECT_NE(foreign.status, 0) << foreign.output;
  EXPECT_FALSE(fs::exists(log)) << foreign.output;
  EXPECT_EQ(test::read_file(user_dir / "notes.txt"), "mine\n");

  const Outcome o = insid(bench + out.string() + " --round-log " + log.string());
  ASSERT_EQ(o.status, 0) << o.output;
  std::istringstream lines(test::read_file(log));
  std::size_t rounds = 0, candidates = 0, evaluations = 0;
  for (std::string line; std::getline(lines, line); ++rounds) {
    const nlohmann::json r = nlohmann::json::parse(line);
    candidates += r.at("candidates").get<std::size_t>();
    EXPECT_LE(r.at("scoring_s").get<double>(), r.at("round_s").get<double>()) << line;
  }
  for (const auto& entry : fs::recursive_directory_iterator(out / "runs"))
    if (entry.path().extension() == ".json")
      evaluations += nlohmann::json::parse(test::read_file(entry.path()))["result"]["evaluations"]
                         .get<std::size_t>();
  EXPECT_GT(rounds, 0u);
  EXPECT_EQ(candidates, evaluations);
}

// nav.csv times are fixed 6-decimal numbers, never 600.00999999999999.
TEST_F(CliSafety, NavigationCsvTimesHaveSixDecimals) {
  const fs::path nav = root_ / "nav.csv";
  const Outcome o = insid("navigate --data " + data_.string() + " --summary " +
                          (root_ / "s.json").string() + " --out " + nav.string());
  ASSERT_EQ(o.status, 0) << o.output;
  std::istringstream in(test::read_file(nav));
  std::string line;
  std::getline(in, line);  // header
  int rows = 0;
  while (std::getline(in, line)) {
    const std::string t = line.substr(0, line.find(','));
    const auto dot = t.find('.');
    ASSERT_NE(dot, std::string::npos) << line;
    ASSERT_EQ(t.size() - dot - 1, 6u) << "line " << rows + 2 << ": " << line;
    ++rows;
  }
  EXPECT_GT(rows, 1000);
}

// navigate --compensate-from: an identify result's estimates, /2 (parameters) or /1 (estimate),
// give the same navigation as the same values given with --compensate; other files are named.
TEST_F(CliSafety, NavigateCompensatesFromAnIdentifyResult) {
  const std::string d = data_.string();
  const fs::path result = root_ / "r.json";
  Outcome o = insid(
      "identify --algo pso --iterations 3 --no-reference-optimum "
      "--uncertainty-replicas 10 --quiet --data " +
      d + " --out " + result.string());
  ASSERT_EQ(o.status, 0) << o.output;
  const nlohmann::json r = nlohmann::json::parse(test::read_file(result));
  ASSERT_TRUE(r.contains("parameters"));
  std::string by_hand;
  char value[64];
  for (const auto& p : r["parameters"]) {
    std::snprintf(value, sizeof value, "%.17g", p["estimate"].get<double>());
    by_hand += " --compensate " + p["name"].get<std::string>() + "=" + value;
  }
  const auto fitness = [&](const std::string& args) {
    const fs::path s = root_ / "s.json";
    const Outcome n = insid("navigate --data " + d + args + " --summary " + s.string());
    EXPECT_EQ(n.status, 0) << args << "\n" << n.output;
    return nlohmann::json::parse(test::read_file(s))["fitness"].get<double>();
  };
  const double f_hand = fitness(by_hand);
  EXPECT_EQ(fitness(" --compensate-from " + result.string()), f_hand);
  EXPECT_NE(fitness(""), f_hand);
  // Schema /1: no "parameters", the "estimate" object.
  nlohmann::json v1 = r;
  v1.erase("parameters");
  v1["format"] = "insid-identify/1";
  const fs::path r1 = root_ / "r1.json";
  std::ofstream(r1) << v1.dump(2);
  EXPECT_EQ(fitness(" --compensate-from " + r1.string()), f_hand);
  // Gyro biases measured at rest (identify --gyro-bias-at-rest) are compensated too.
  nlohmann::json at_rest = r;
  nlohmann::json kept = nlohmann::json::array();
  for (const auto& p : r["parameters"])
    if (p["name"].get<std::string>().rfind("gyro_bias_", 0) != 0) kept.push_back(p);
  at_rest["parameters"] = kept;
  at_rest["gyro_bias_at_rest"] = {{"bias_deg_s", {0.1, -0.05, 0.02}}};
  const fs::path rr = root_ / "rest.json";
  std::ofstream(rr) << at_rest.dump(2);
  std::string rest_by_hand;
  for (const auto& p : kept) {
    std::snprintf(value, sizeof value, "%.17g", p["estimate"].get<double>());
    rest_by_hand += " --compensate " + p["name"].get<std::string>() + "=" + value;
  }
  const char* names[3] = {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z"};
  const double deg_s[3] = {0.1, -0.05, 0.02};
  for (int i = 0; i < 3; ++i) {
    std::snprintf(value, sizeof value, "%.17g", deg_s[i] * std::numbers::pi / 180.0);
    rest_by_hand += std::string(" --compensate ") + names[i] + "=" + value;
  }
  EXPECT_EQ(fitness(" --compensate-from " + rr.string()), fitness(rest_by_hand));
  // An effect in both: refused.
  const std::string first = r["parameters"][0]["name"].get<std::string>();
  o = insid("navigate --data " + d + " --compensate-from " + result.string() + " --compensate " +
            first + "=0");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--compensate " + first + " is also in --compensate-from"))
      << o.output;
  // Not an identify result; a broken estimate.
  nlohmann::json bad = v1;
  bad["format"] = "insid-run/2";
  std::ofstream(r1, std::ios::trunc) << bad.dump(2);
  o = insid("navigate --data " + d + " --compensate-from " + r1.string());
  EXPECT_EQ(o.status, 1);
  EXPECT_TRUE(test::contains(o.output, "not an identify result (\"format\" is 'insid-run/2'"))
      << o.output;
  bad = v1;
  bad["estimate"][first] = "big";
  std::ofstream(r1, std::ios::trunc) << bad.dump(2);
  o = insid("navigate --data " + d + " --compensate-from " + r1.string());
  EXPECT_EQ(o.status, 1);
  EXPECT_TRUE(
      test::contains(o.output, "estimate." + first + " is \"big\", expected a finite number"))
      << o.output;
}

// A log whose second half is sampled at 10 Hz passed the 20 Hz minimum on its median
// step. GIVEN a KF-GINS export of a 100 Hz flight with every tenth row kept in its second half
// WHEN it is imported THEN it is refused, saying how much of the log is slow, and nothing is
// written; the untouched export imports.
TEST_F(CliSafety, AMixedRateImuLogIsRefusedThoughItsMedianPasses) {
  const fs::path kf = root_ / "kf";
  Outcome o = insid("export --to kf-gins --data " + data_.string() + " --out " + kf.string());
  ASSERT_EQ(o.status, 0) << o.output;
  std::istringstream in(test::read_file(kf / "imu.txt"));
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_GT(lines.size(), 1000u);
  std::ofstream mixed(root_ / "mixed_imu.txt");
  for (std::size_t k = 0; k < lines.size(); ++k)
    if (k < lines.size() * 55 / 100 || k % 10 == 0) mixed << lines[k] << "\n";
  mixed.close();
  const std::string common = " --gnss " + (kf / "gnss.txt").string() +
                             " --align-s 600 --static-rate 5 --static-accel-sd 0.3 --out ";
  o = insid("import kf-gins --imu " + (root_ / "mixed_imu.txt").string() + common +
            (root_ / "mixed").string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("is sampled slower than the 20 Hz insid accepts"), std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(root_ / "mixed"));
  o = insid("import kf-gins --imu " + (kf / "imu.txt").string() + common +
            (root_ / "whole").string());
  EXPECT_EQ(o.status, 0) << o.output;
}

}  // namespace manners
