// The malformed-dataset battery: one valid simulated dataset, mutated one way per case (a bad
// number in every column of every file, values beyond the plausibility bounds, broken headers
// and lines, declared rates that the data contradict, gaps, cut files). Every case must be
// refused with a DatasetError whose message names the file, the line (or meta.json field) and
// what was expected.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "data/dataset.h"
#include "scenarios/scenario.h"
#include "test_support/files.h"

namespace insid {
namespace {
namespace fs = std::filesystem;

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.push_back("");
  return parts;
}

std::string join(const std::vector<std::string>& parts, char sep) {
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i) out += (i ? std::string(1, sep) : "") + parts[i];
  return out;
}

// Replace field `column` (0-based) of `line` (1-based, the header is line 1).
void set_field(const fs::path& file, int line, int column, const std::string& value) {
  std::vector<std::string> lines = split(test::read_file(file), '\n');
  std::vector<std::string> fields = split(lines.at(static_cast<std::size_t>(line - 1)), ',');
  fields.at(static_cast<std::size_t>(column)) = value;
  lines[static_cast<std::size_t>(line - 1)] = join(fields, ',');
  test::write_file(file, join(lines, '\n'));
}

void edit_lines(const fs::path& file, const std::function<void(std::vector<std::string>&)>& edit) {
  std::vector<std::string> lines = split(test::read_file(file), '\n');
  edit(lines);
  test::write_file(file, join(lines, '\n'));
}

// Replace the value of a top-level number in meta.json by `text`.
void set_meta_number(const fs::path& dir, const std::string& key, const std::string& text) {
  std::string meta = test::read_file(dir / "meta.json");
  const auto at = meta.find("\"" + key + "\"");
  const auto colon = meta.find(':', at);
  const auto end = meta.find_first_of(",}", colon);
  test::write_file(dir / "meta.json", meta.substr(0, colon + 1) + " " + text + meta.substr(end));
}

struct Case {
  std::string name;
  std::function<void(const fs::path&)> mutate;
  std::vector<std::string> expected;  // substrings of the error message
  bool with_heading = false;          // mutates the valid dataset that has a heading.csv
};

// meta.json text with `from` replaced by `to` (once; the test fails when `from` is absent).
void replace_in_meta(const fs::path& dir, const std::string& from, const std::string& to) {
  std::string meta = test::read_file(dir / "meta.json");
  const auto at = meta.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  meta.replace(at, from.size(), to);
  test::write_file(dir / "meta.json", meta);
}

// meta.json without its "heading" block.
void remove_meta_heading(const fs::path& dir) {
  std::string meta = test::read_file(dir / "meta.json");
  const auto at = meta.find("\"heading\"");
  ASSERT_NE(at, std::string::npos);
  const auto close = meta.find('}', at);
  const auto comma = meta.find(',', close);
  meta.erase(at, comma + 1 - at);
  test::write_file(dir / "meta.json", meta);
}

const std::vector<std::string> kHeadingColumns = {"t_s", "heading_deg", "sd_deg"};

// heading.csv and its meta.json block, one mutation each.
void add_heading_cases(std::vector<Case>& cases) {
  const std::vector<std::pair<std::string, std::string>> not_numbers = {
      {"nan", "nan"}, {"inf", "inf"}, {"word", "abc"}, {"empty", ""}, {"overflow", "1e999"}};
  for (std::size_t c = 0; c < kHeadingColumns.size(); ++c)
    for (const auto& [label, text] : not_numbers) {
      const int col = static_cast<int>(c);
      const std::string value = text;
      cases.push_back(
          {"heading_" + kHeadingColumns[c] + "_" + label,
           [col, value](const fs::path& d) { set_field(d / "heading.csv", 7, col, value); },
           {"heading.csv line 7", kHeadingColumns[c]},
           true});
    }
  for (const std::string value : {"400", "-361", "1e9"})
    cases.push_back({"heading_beyond_" + value,
                     [value](const fs::path& d) { set_field(d / "heading.csv", 9, 1, value); },
                     {"heading.csv line 9", "heading_deg", "plausibility bound"},
                     true});
  for (const std::string value : {"0", "-1", "200"})
    cases.push_back({"heading_sd_" + value,
                     [value](const fs::path& d) { set_field(d / "heading.csv", 9, 2, value); },
                     {"heading.csv line 9", "sd_deg", "must lie in (0, 180] deg"},
                     true});
  cases.push_back({"heading_time_repeats",
                   [](const fs::path& d) {
                     edit_lines(d / "heading.csv", [](std::vector<std::string>& l) {
                       auto f = split(l[9], ',');
                       f[0] = split(l[8], ',')[0];
                       l[9] = join(f, ',');
                     });
                   },
                   {"heading.csv line 10", "t_s", "repeats"},
                   true});
  cases.push_back({"heading_time_backwards",
                   [](const fs::path& d) { set_field(d / "heading.csv", 10, 0, "-1"); },
                   {"heading.csv line 10", "t_s", "strictly increasing"},
                   true});
  cases.push_back({"heading_header_renamed",
                   [](const fs::path& d) { set_field(d / "heading.csv", 1, 1, "yaw_deg"); },
                   {"heading.csv line 1", "heading_deg", "header"},
                   true});
  cases.push_back({"heading_header_without_sd_rows_with",
                   [](const fs::path& d) {
                     edit_lines(d / "heading.csv",
                                [](std::vector<std::string>& l) { l[0] = "t_s,heading_deg"; });
                   },
                   {"heading.csv line 2", "too many fields"},
                   true});
  cases.push_back({"heading_short_line",
                   [](const fs::path& d) {
                     edit_lines(d / "heading.csv", [](std::vector<std::string>& l) {
                       l[19] = l[19].substr(0, l[19].rfind(','));
                     });
                   },
                   {"heading.csv line 20", "sd_deg", "truncated row"},
                   true});
  cases.push_back(
      {"heading_only_header",
       [](const fs::path& d) { test::write_file(d / "heading.csv", "t_s,heading_deg,sd_deg\n"); },
       {"meta.json", "\"heading\"", "no heading.csv"},
       true});
  cases.push_back({"heading_file_without_meta",
                   [](const fs::path& d) { remove_meta_heading(d); },
                   {"heading.csv", "needs its source in meta.json"},
                   true});
  cases.push_back({"heading_meta_without_file",
                   [](const fs::path& d) { fs::remove(d / "heading.csv"); },
                   {"meta.json", "\"heading\"", "no heading.csv"},
                   true});
  cases.push_back(
      {"heading_source_unknown",
       [](const fs::path& d) { replace_in_meta(d, "\"dual_antenna\"", "\"compass\""); },
       {"meta.json: heading.source: expected \"dual_antenna\" or \"magnetometer\", found a string "
        "\"compass\""},
       true});
  cases.push_back(
      {"heading_magnetometer_without_declination",
       [](const fs::path& d) { replace_in_meta(d, "\"dual_antenna\"", "\"magnetometer\""); },
       {"meta.json", "heading.declination_deg", "required for a magnetometer"},
       true});
  cases.push_back({"heading_dual_antenna_with_declination",
                   [](const fs::path& d) {
                     replace_in_meta(d, "\"dual_antenna\"",
                                     "\"dual_antenna\", \"declination_deg\": 3");
                   },
                   {"meta.json", "heading.declination_deg", "only for a magnetometer"},
                   true});
  cases.push_back({"heading_declination_beyond",
                   [](const fs::path& d) {
                     replace_in_meta(d, "\"dual_antenna\"",
                                     "\"magnetometer\", \"declination_deg\": 200");
                   },
                   {"meta.json", "heading.declination_deg", "[-180, 180]"},
                   true});
  // meta.json "motors" (the motor schedule): each interval checked, named by its index.
  const auto with_motors = [](const std::string& block) {
    return [block](const fs::path& d) {
      replace_in_meta(d, "\"align_s\"", "\"motors\": " + block + ", \"align_s\"");
    };
  };
  cases.push_back({"motors_overlapping",
                   with_motors(R"({"source": "x", "on_s": [[1, 5], [4, 6]]})"),
                   {"meta.json", "motors.on_s", "motor interval 1", "overlaps"}});
  cases.push_back({"motors_reversed",
                   with_motors(R"({"source": "x", "on_s": [[5, 1]]})"),
                   {"meta.json", "motor interval 0", "must start before it ends"}});
  cases.push_back({"motors_three_numbers",
                   with_motors(R"({"source": "x", "on_s": [[1, 2, 3]]})"),
                   {"meta.json", "motors.on_s[0]", "expected [on_s, off_s]"}});
  cases.push_back({"motors_without_source",
                   with_motors(R"({"on_s": [[1, 2]]})"),
                   {"meta.json", "motors.source", "missing"}});
  cases.push_back({"heading_unknown_field",
                   [](const fs::path& d) {
                     replace_in_meta(d, "\"dual_antenna\"", "\"dual_antenna\", \"frame\": 1");
                   },
                   {"meta.json: heading.frame: unknown key (valid keys: source, declination_deg)"},
                   true});
  cases.push_back({"heading_value_edited",
                   [](const fs::path& d) {
                     edit_lines(d / "heading.csv", [](std::vector<std::string>& l) {
                       l[5].back() = l[5].back() == '1' ? '2' : '1';
                     });
                   },
                   {"heading.csv: its values differ", "files.heading.csv.sha256"},
                   true});
  cases.push_back({"heading_fifo",
                   [](const fs::path& d) {
                     fs::remove(d / "heading.csv");
                     ASSERT_EQ(::mkfifo((d / "heading.csv").c_str(), 0644), 0);
                   },
                   {"heading.csv", "not a regular file (a FIFO)"},
                   true});
}

const std::vector<std::string> kImuColumns = {
    "t_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps"};
const std::vector<std::string> kGnssColumns = {"t_s",    "lat_deg", "lon_deg", "h_m",
                                               "vE_mps", "vN_mps",  "vU_mps"};
const std::vector<std::string> kTruthColumns = {"t_s",       "lat_deg", "lon_deg", "h_m",
                                                "vE_mps",    "vN_mps",  "vU_mps",  "roll_deg",
                                                "pitch_deg", "yaw_deg"};

std::vector<Case> make_cases() {
  std::vector<Case> cases;
  // Text that is not a finite number, in every column of every file.
  const std::vector<std::pair<std::string, std::string>> not_numbers = {
      {"nan", "nan"}, {"inf", "inf"}, {"word", "abc"}, {"empty", ""}, {"overflow", "1e999"}};
  const std::vector<std::pair<std::string, const std::vector<std::string>*>> files = {
      {"imu.csv", &kImuColumns}, {"gnss.csv", &kGnssColumns}, {"truth.csv", &kTruthColumns}};
  for (const auto& [file, columns] : files) {
    for (std::size_t c = 0; c < columns->size(); ++c) {
      for (const auto& [label, text] : not_numbers) {
        const std::string f = file;
        const int col = static_cast<int>(c);
        const std::string value = text;
        cases.push_back({f.substr(0, f.find('.')) + "_" + (*columns)[c] + "_" + label,
                         [f, col, value](const fs::path& d) { set_field(d / f, 7, col, value); },
                         {f + " line 7", (*columns)[c]}});
      }
    }
  }
  // Beyond the plausibility bounds (one IMU value of 1e300; a deletion that turns -0.0979
  // into -9.8e15; positions off the Earth; impossible speeds).
  for (int c = 1; c <= 6; ++c) {
    for (const std::string value : {"1e300", "-9.8e15", "1e6"}) {
      cases.push_back(
          {"imu_" + kImuColumns[static_cast<std::size_t>(c)] + "_" + value,
           [c, value](const fs::path& d) { set_field(d / "imu.csv", 30, c, value); },
           {"imu.csv line 30", kImuColumns[static_cast<std::size_t>(c)], "plausibility bound"}});
    }
  }
  for (const std::string file : {"gnss.csv", "truth.csv"}) {
    const std::vector<std::tuple<std::string, int, std::string, std::string>> off_earth = {
        {"lon_big", 2, "1e6", "plausibility bound"},
        {"lon_low", 2, "-400", "plausibility bound"},
        {"height_high", 3, "1e12", "plausible"},
        {"height_low", 3, "-5000", "plausible"},
        {"vE_fast", 4, "1e200", "plausibility bound"},
        {"vN_fast", 5, "-2000", "plausibility bound"},
        {"vU_fast", 6, "1e4", "plausibility bound"},
        {"lat_pole", 1, "90", "strictly within"},
        {"lat_beyond", 1, "-123", "strictly within"}};
    for (const auto& [label, col, value, why] : off_earth) {
      const std::vector<std::string>& columns = file == "gnss.csv" ? kGnssColumns : kTruthColumns;
      cases.push_back(
          {file.substr(0, file.find('.')) + "_" + label,
           [file, col, value](const fs::path& d) { set_field(d / file, 12, col, value); },
           {file + " line 12", columns[static_cast<std::size_t>(col)], why}});
    }
  }
  // Times: repeated, backwards, an IMU step off the declared rate, a GNSS gap.
  for (const std::string file : {"imu.csv", "gnss.csv", "truth.csv"}) {
    cases.push_back({file.substr(0, file.find('.')) + "_time_repeats",
                     [file](const fs::path& d) {
                       edit_lines(d / file, [](std::vector<std::string>& l) {
                         auto f = split(l[9], ',');
                         f[0] = split(l[8], ',')[0];
                         l[9] = join(f, ',');
                       });
                     },
                     {file + " line 10", "t_s", "repeats"}});
    cases.push_back({file.substr(0, file.find('.')) + "_time_backwards",
                     [file](const fs::path& d) { set_field(d / file, 10, 0, "-1"); },
                     {file + " line 10", "t_s", "strictly increasing"}});
  }
  cases.push_back({"imu_step_jump",
                   [](const fs::path& d) {
                     edit_lines(d / "imu.csv",
                                [](std::vector<std::string>& l) { l.erase(l.begin() + 40); });
                   },
                   {"imu.csv line 41", "t_s", "IMU step"}});
  cases.push_back({"gnss_gap_90s",
                   [](const fs::path& d) {
                     edit_lines(d / "gnss.csv", [](std::vector<std::string>& l) {
                       l.erase(l.begin() + 50, l.begin() + 50 + 900);
                     });
                   },
                   {"gnss.csv line 51", "GNSS gap of 90"}});
  cases.push_back({"gnss_two_rows",
                   [](const fs::path& d) {
                     edit_lines(d / "gnss.csv", [](std::vector<std::string>& l) {
                       l.erase(l.begin() + 2, l.end() - 2);
                     });
                   },
                   {"gnss.csv line 3", "GNSS gap"}});
  cases.push_back({"gnss_ends_early",
                   [](const fs::path& d) {
                     edit_lines(d / "gnss.csv", [](std::vector<std::string>& l) {
                       l.erase(l.end() - 40, l.end() - 1);
                     });
                   },
                   {"gnss.csv line", "does not cover the end"}});
  // Declared rates the data contradict.
  for (const std::string rate : {"1", "1e-9", "11.5", "100"}) {
    cases.push_back({"gnss_rate_" + rate,
                     [rate](const fs::path& d) { set_meta_number(d, "gnss_rate_hz", rate); },
                     {"meta.json", "gnss_rate_hz"}});
  }
  for (const std::string rate : {"50", "101.5", "0", "-100"}) {
    cases.push_back({"imu_rate_" + rate,
                     [rate](const fs::path& d) { set_meta_number(d, "imu_rate_hz", rate); },
                     {rate == "0" || rate == "-100" ? "meta.json" : "imu.csv",
                      rate == "0" || rate == "-100" ? "imu_rate_hz" : "IMU step"}});
  }
  // meta.json: a number beyond double (found by the fuzzer), a key given twice.
  cases.push_back({"meta_number_overflow",
                   [](const fs::path& d) { set_meta_number(d, "align_s", "7.2e0824"); },
                   {"meta.json", "not valid JSON", "number overflow"}});
  cases.push_back({"meta_duplicate_key",
                   [](const fs::path& d) {
                     std::string meta = test::read_file(d / "meta.json");
                     meta.insert(meta.find('{') + 1, "\"imu_rate_hz\": 100,");
                     test::write_file(d / "meta.json", meta);
                   },
                   {"meta.json: imu_rate_hz: key given twice in one object"}});
  // A data file cut at a line boundary, or one value edited: the rows and digest insid recorded.
  cases.push_back({"imu_cut_at_line_boundary",
                   [](const fs::path& d) {
                     edit_lines(d / "imu.csv",
                                [](std::vector<std::string>& l) { l.resize(l.size() - 3); });
                   },
                   {"imu.csv: holds", "files.imu.csv.rows"}});
  cases.push_back({"gnss_value_edited",
                   [](const fs::path& d) {
                     edit_lines(d / "gnss.csv", [](std::vector<std::string>& l) {
                       l[5].back() = l[5].back() == '1' ? '2' : '1';
                     });
                   },
                   {"gnss.csv: its values differ", "files.gnss.csv.sha256"}});
  // Headers and line structure.
  for (const std::string file : {"imu.csv", "gnss.csv", "truth.csv"}) {
    const std::string stem = file.substr(0, file.find('.'));
    cases.push_back({stem + "_header_renamed",
                     [file](const fs::path& d) { set_field(d / file, 1, 1, "speed"); },
                     {file, "header"}});
    cases.push_back({stem + "_header_missing_column",
                     [file](const fs::path& d) {
                       edit_lines(d / file, [](std::vector<std::string>& l) {
                         auto f = split(l[0], ',');
                         f.pop_back();
                         l[0] = join(f, ',');
                       });
                     },
                     {file, "header"}});
    cases.push_back({stem + "_short_line",
                     [file](const fs::path& d) {
                       edit_lines(d / file, [](std::vector<std::string>& l) {
                         auto f = split(l[19], ',');
                         f.pop_back();
                         l[19] = join(f, ',');
                       });
                     },
                     {file + " line 20"}});
    cases.push_back({stem + "_long_line",
                     [file](const fs::path& d) {
                       edit_lines(d / file, [](std::vector<std::string>& l) { l[19] += ",1"; });
                     },
                     {file + " line 20"}});
    cases.push_back({stem + "_blank_line_inside",
                     [file](const fs::path& d) {
                       edit_lines(d / file, [](std::vector<std::string>& l) { l[19] = ""; });
                     },
                     {file + " line 20"}});
  }
  for (const std::string file : {"imu.csv", "gnss.csv", "meta.json"}) {
    cases.push_back({file.substr(0, file.find('.')) + "_missing",
                     [file](const fs::path& d) { fs::remove(d / file); },
                     {file}});
    cases.push_back({file.substr(0, file.find('.')) + "_empty",
                     [file](const fs::path& d) { test::write_file(d / file, ""); },
                     {file}});
  }
  // Special files: a FIFO must not hang the loader, broken links are not "missing".
  cases.push_back({"imu_fifo",
                   [](const fs::path& d) {
                     fs::remove(d / "imu.csv");
                     ASSERT_EQ(::mkfifo((d / "imu.csv").c_str(), 0644), 0);
                   },
                   {"imu.csv", "not a regular file (a FIFO)"}});
  cases.push_back({"imu_symlink_loop",
                   [](const fs::path& d) {
                     fs::remove(d / "imu.csv");
                     fs::create_symlink("imu.csv", d / "imu.csv");
                   },
                   {"imu.csv", "symbolic link that does not resolve"}});
  cases.push_back({"truth_dangling_link",
                   [](const fs::path& d) {
                     fs::remove(d / "truth.csv");
                     fs::create_symlink("elsewhere.csv", d / "truth.csv");
                   },
                   {"truth.csv", "symbolic link that does not resolve"}});
  cases.push_back({"gnss_is_a_directory",
                   [](const fs::path& d) {
                     fs::remove(d / "gnss.csv");
                     fs::create_directory(d / "gnss.csv");
                   },
                   {"gnss.csv", "not a regular file"}});
  add_heading_cases(cases);
  return cases;
}

class DatasetBattery : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    valid_ = new fs::path(test::fresh_dir("battery-valid"));
    scenarios::ScenarioConfig flight = scenarios::preset_scenario("straight");
    flight.align_s = 20.0;
    flight.flight_s = 100.0;
    const Dataset dataset = scenarios::simulate(flight);
    write_dataset(*valid_, dataset);
    valid_heading_ = new fs::path(valid_->string() + "-heading");
    fs::remove_all(*valid_heading_);
    write_dataset(*valid_heading_, with_heading(dataset));
  }
  // The dataset with a dual-antenna heading every 10th truth row (truth yaw, sd 0.5 deg).
  static Dataset with_heading(Dataset dataset) {
    for (std::size_t i = 0; i < dataset.truth.size(); i += 10)
      dataset.heading.push_back(
          {dataset.truth[i].t_s, dataset.truth[i].attitude.yaw_rad, 0.5 * 3.14159265358979 / 180});
    dataset.meta.heading = HeadingMeta{};
    return dataset;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*valid_);
    fs::remove_all(*valid_heading_);
    delete valid_;
    delete valid_heading_;
  }
  static fs::path* valid_;
  static fs::path* valid_heading_;
};
fs::path* DatasetBattery::valid_ = nullptr;
fs::path* DatasetBattery::valid_heading_ = nullptr;

TEST_F(DatasetBattery, EveryMalformedCaseIsRefusedWithFileLineAndExpectation) {
  ASSERT_NO_THROW(load_dataset(*valid_));
  ASSERT_NO_THROW(load_dataset(*valid_heading_));
  const std::vector<Case> cases = make_cases();
  EXPECT_GE(cases.size(), 100u);
  const fs::path work = valid_->string() + "-case";
  int refused = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    fs::remove_all(work);
    fs::copy(c.with_heading ? *valid_heading_ : *valid_, work);
    c.mutate(work);
    try {
      load_dataset(work);
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const DatasetError& e) {
      ++refused;
      for (const std::string& part : c.expected)
        EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
            << c.name << ": message lacks '" << part << "': " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << c.name << ": not a DatasetError: " << e.what();
    }
  }
  fs::remove_all(work);
  std::printf("[ measured ] %d of %zu malformed datasets refused\n", refused, cases.size());
}

// A heading round-trips bit for bit (with and without the sd column, both source kinds), and a
// dataset without one writes no heading.csv, no "heading" block, and keeps its digest.
TEST_F(DatasetBattery, HeadingRoundTripsAndItsAbsenceChangesNothing) {
  const Dataset plain = load_dataset(*valid_);
  EXPECT_TRUE(plain.heading.empty());
  EXPECT_FALSE(plain.meta.heading.has_value());
  EXPECT_FALSE(fs::exists(*valid_ / "heading.csv"));
  EXPECT_EQ(test::read_file(*valid_ / "meta.json").find("heading"), std::string::npos);

  const Dataset written = with_heading(plain);
  const Dataset back = load_dataset(*valid_heading_);
  ASSERT_EQ(back.heading.size(), written.heading.size());
  for (std::size_t i = 0; i < back.heading.size(); ++i) {
    EXPECT_EQ(back.heading[i].t_s, written.heading[i].t_s);
    EXPECT_EQ(back.heading[i].yaw_rad, written.heading[i].yaw_rad) << i;
    ASSERT_TRUE(back.heading[i].sd_rad.has_value());
    EXPECT_EQ(*back.heading[i].sd_rad, *written.heading[i].sd_rad);
  }
  ASSERT_TRUE(back.meta.heading.has_value());
  EXPECT_EQ(back.meta.heading->source, HeadingSourceKind::kDualAntenna);
  // The heading enters the digest only when present.
  EXPECT_NE(dataset_digest(*valid_heading_), dataset_digest(*valid_));

  Dataset mag = written;
  for (HeadingSample& h : mag.heading) h.sd_rad.reset();
  mag.meta.heading = HeadingMeta{HeadingSourceKind::kMagnetometer, -2.5};
  const fs::path dir = valid_->string() + "-mag";
  write_dataset(dir, mag);
  EXPECT_EQ(test::read_file(dir / "heading.csv").substr(0, 16), "t_s,heading_deg\n");
  const Dataset mag_back = load_dataset(dir);
  ASSERT_EQ(mag_back.heading.size(), mag.heading.size());
  EXPECT_FALSE(mag_back.heading[3].sd_rad.has_value());
  EXPECT_EQ(mag_back.heading[3].yaw_rad, mag.heading[3].yaw_rad);
  ASSERT_TRUE(mag_back.meta.heading && mag_back.meta.heading->declination_deg);
  EXPECT_EQ(mag_back.meta.heading->source, HeadingSourceKind::kMagnetometer);
  EXPECT_EQ(*mag_back.meta.heading->declination_deg, -2.5);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insid
