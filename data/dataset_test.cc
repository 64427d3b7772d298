#include "data/dataset.h"

#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "model/rotation.h"
#include "test_support/files.h"

namespace insid {
namespace {

namespace fs = std::filesystem;

::testing::AssertionResult Contains(const char* text_expr, const char*, const std::string& text,
                                    const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << text_expr << " = \"" << text << "\"\ndoes not contain \"" << part << "\"";
}
#define EXPECT_CONTAINS(text, part) EXPECT_PRED_FORMAT2(Contains, text, part)

// ---- helpers --------------------------------------------------------------------------------

std::vector<std::string> split_lines(const std::string& s) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < s.size()) {
    const std::size_t nl = s.find('\n', start);
    lines.push_back(s.substr(start, nl == std::string::npos ? std::string::npos : nl - start));
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  return lines;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

// Replace 1-based line `line_no` of a file.
void replace_line(const fs::path& p, std::size_t line_no, const std::string& text) {
  auto lines = split_lines(test::read_file(p));
  ASSERT_LE(line_no, lines.size());
  lines[line_no - 1] = text;
  test::write_file(p, join_lines(lines));
}

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

#define EXPECT_SAME_BITS(a, b) \
  EXPECT_EQ(bits(a), bits(b)) << #a " = " << (a) << ", " #b " = " << (b)

void expect_identical(const TruthSample& a, const TruthSample& b) {
  EXPECT_SAME_BITS(a.t_s, b.t_s);
  EXPECT_SAME_BITS(a.lat_rad, b.lat_rad);
  EXPECT_SAME_BITS(a.lon_rad, b.lon_rad);
  EXPECT_SAME_BITS(a.h_m, b.h_m);
  for (int k = 0; k < 3; ++k) EXPECT_SAME_BITS(a.v_eb_n_mps[k], b.v_eb_n_mps[k]);
  EXPECT_SAME_BITS(a.attitude.roll_rad, b.attitude.roll_rad);
  EXPECT_SAME_BITS(a.attitude.pitch_rad, b.attitude.pitch_rad);
  EXPECT_SAME_BITS(a.attitude.yaw_rad, b.attitude.yaw_rad);
}

void expect_identical(const Dataset& a, const Dataset& b) {
  const DatasetMeta &ma = a.meta, &mb = b.meta;
  EXPECT_SAME_BITS(ma.imu_rate_hz, mb.imu_rate_hz);
  EXPECT_SAME_BITS(ma.gnss_rate_hz, mb.gnss_rate_hz);
  EXPECT_SAME_BITS(ma.earth.ellipsoid.a_m, mb.earth.ellipsoid.a_m);
  EXPECT_SAME_BITS(ma.earth.ellipsoid.f, mb.earth.ellipsoid.f);
  EXPECT_SAME_BITS(ma.earth.omega_ie_rad_s, mb.earth.omega_ie_rad_s);
  EXPECT_SAME_BITS(ma.earth.g_eq_mps2, mb.earth.g_eq_mps2);
  EXPECT_SAME_BITS(ma.align_s, mb.align_s);
  expect_identical(ma.initial, mb.initial);
  ASSERT_EQ(ma.injected.has_value(), mb.injected.has_value());
  if (ma.injected) {
    ASSERT_EQ(ma.injected->size(), mb.injected->size());
    for (const auto& [name, v] : *ma.injected) {
      ASSERT_TRUE(mb.injected->count(name)) << name;
      EXPECT_SAME_BITS(v, mb.injected->at(name));
    }
  }
  ASSERT_EQ(ma.noise.has_value(), mb.noise.has_value());
  if (ma.noise) {
    EXPECT_SAME_BITS(ma.noise->arw_deg_rth, mb.noise->arw_deg_rth);
    EXPECT_SAME_BITS(ma.noise->vrw_mps_rth, mb.noise->vrw_mps_rth);
    EXPECT_SAME_BITS(ma.noise->gnss_vel_sigma_mps, mb.noise->gnss_vel_sigma_mps);
    EXPECT_SAME_BITS(ma.noise->gnss_pos_sigma_m, mb.noise->gnss_pos_sigma_m);
  }
  ASSERT_EQ(a.imu.size(), b.imu.size());
  for (std::size_t i = 0; i < a.imu.size(); ++i) {
    EXPECT_SAME_BITS(a.imu[i].t_s, b.imu[i].t_s);
    for (int k = 0; k < 3; ++k) {
      EXPECT_SAME_BITS(a.imu[i].dtheta_b_rad[k], b.imu[i].dtheta_b_rad[k]);
      EXPECT_SAME_BITS(a.imu[i].dv_b_mps[k], b.imu[i].dv_b_mps[k]);
    }
  }
  ASSERT_EQ(a.gnss.size(), b.gnss.size());
  for (std::size_t i = 0; i < a.gnss.size(); ++i) {
    EXPECT_SAME_BITS(a.gnss[i].t_s, b.gnss[i].t_s);
    EXPECT_SAME_BITS(a.gnss[i].lat_rad, b.gnss[i].lat_rad);
    EXPECT_SAME_BITS(a.gnss[i].lon_rad, b.gnss[i].lon_rad);
    EXPECT_SAME_BITS(a.gnss[i].h_m, b.gnss[i].h_m);
    for (int k = 0; k < 3; ++k) EXPECT_SAME_BITS(a.gnss[i].v_eb_n_mps[k], b.gnss[i].v_eb_n_mps[k]);
  }
  ASSERT_EQ(a.truth.size(), b.truth.size());
  for (std::size_t i = 0; i < a.truth.size(); ++i) expect_identical(a.truth[i], b.truth[i]);
}

// A small valid dataset: 100 Hz IMU over 30 s, 10 Hz GNSS, 10 s alignment. Angles are built
// from degree values (as real data are), noisy full-precision doubles everywhere.
Dataset make_dataset(bool with_truth, bool with_injected, bool with_noise,
                     std::size_t imu_rows = 3001) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Dataset ds;
  ds.meta.imu_rate_hz = 100.0;
  ds.meta.gnss_rate_hz = 10.0;
  ds.meta.earth = EarthModel::paper(40.068 * kDegToRad, 50.0);
  ds.meta.align_s = 10.0;
  ds.meta.initial.t_s = 0.0;
  ds.meta.initial.lat_rad = 40.068 * kDegToRad;
  ds.meta.initial.lon_rad = 116.246 * kDegToRad;
  ds.meta.initial.h_m = 50.0;
  ds.meta.initial.attitude = {0.1 * kDegToRad, -0.2 * kDegToRad, 271.5 * kDegToRad};
  if (with_injected)
    ds.meta.injected = std::map<std::string, double>{{"accel_bias_x", -0.001},
                                                     {"accel_bias_y", 0.00075},
                                                     {"gyro_bias_x", 2 * 0.01 * kDegToRad / 3600},
                                                     {"gyro_bias_y", -1.5e-8 / 3.0}};
  if (with_noise) ds.meta.noise = NoiseLevels{0.002, 0.0005 / 3.0, 0.02, 0.5};
  for (std::size_t i = 0; i < imu_rows; ++i) {
    ImuSample s;
    s.t_s = static_cast<double>(i) / 100.0;
    s.dtheta_b_rad = {1e-6 * u(rng), 1e-6 * u(rng), 1e-4 * u(rng)};
    s.dv_b_mps = {1e-3 * u(rng), 1e-3 * u(rng), -0.098 + 1e-4 * u(rng)};
    ds.imu.push_back(s);
  }
  const double t_end = ds.imu.back().t_s;
  for (std::size_t i = 0; static_cast<double>(i) / 10.0 <= t_end + 1e-9; ++i) {
    GnssSample g;
    g.t_s = static_cast<double>(i) / 10.0;
    g.lat_rad = (40.068 + 1e-4 * u(rng)) * kDegToRad;
    g.lon_rad = (-116.246 + 1e-4 * u(rng)) * kDegToRad;
    g.h_m = 50.0 + u(rng);
    g.v_eb_n_mps = {10 * u(rng), 10 * u(rng), 0.1 * u(rng)};
    ds.gnss.push_back(g);
    if (with_truth) {
      TruthSample t;
      t.t_s = g.t_s;
      t.lat_rad = g.lat_rad;
      t.lon_rad = (116.246 + 1e-4 * u(rng)) * kDegToRad;
      t.h_m = g.h_m + 0.1 * u(rng);
      t.v_eb_n_mps = g.v_eb_n_mps;
      t.attitude = {(2 * u(rng)) * kDegToRad, (3 * u(rng)) * kDegToRad,
                    (180 + 179 * u(rng)) * kDegToRad};
      ds.truth.push_back(t);
    }
  }
  return ds;
}

class DatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = test::fresh_dir(std::string("dataset-test-") + info->name());
    fs::create_directories(root_);
    dir_ = root_ / "ds";
  }
  void TearDown() override { fs::remove_all(root_); }

  // Write a valid dataset (with truth) to dir_.
  void write_valid(bool with_truth = true) {
    write_dataset(dir_, make_dataset(with_truth, true, true));
  }

  // Drop the "files" record from dir_'s meta.json: the dataset becomes one made by hand, whose
  // data files may be edited (tests that edit data on purpose to reach another check use this).
  void forget_recorded_files() {
    nlohmann::json meta = nlohmann::json::parse(test::read_file(dir_ / "meta.json"));
    ASSERT_TRUE(meta.contains("files"));
    meta.erase("files");
    test::write_file(dir_ / "meta.json", meta.dump(2));
  }

  // Load dir_, expecting a DatasetError; return its message.
  std::string load_error() {
    try {
      load_dataset(dir_);
    } catch (const DatasetError& e) {
      return e.what();
    }
    ADD_FAILURE() << "load_dataset did not throw";
    return {};
  }

  std::vector<std::string> entries(const fs::path& p) const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(p)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path root_, dir_;
};

// ---- round trips ----------------------------------------------------------------------------

TEST_F(DatasetTest, RoundTripIsBitIdenticalWithTruthInjectedAndNoise) {
  const Dataset ds = make_dataset(true, true, true);
  write_dataset(dir_, ds);
  EXPECT_EQ(entries(dir_),
            (std::vector<std::string>{"gnss.csv", "imu.csv", "meta.json", "truth.csv"}));
  const Dataset back = load_dataset(dir_);
  expect_identical(ds, back);
  // Nothing else left next to the dataset (no temporary directories).
  EXPECT_EQ(entries(root_), std::vector<std::string>{"ds"});
  // Degrees are written as the short decimal they came from.
  EXPECT_CONTAINS(test::read_file(dir_ / "meta.json"), "\"lat_deg\": 40.068");
  EXPECT_CONTAINS(test::read_file(dir_ / "meta.json"), "\"yaw_deg\": 271.5");
}

TEST_F(DatasetTest, MotorScheduleRoundTripsAndIsOptional) {
  Dataset ds = make_dataset(false, false, false);
  ds.meta.motors.on_s = {{0.1234567890123, 0.5}, {0.75, 1.0 / 3.0 + 1.0}};
  ds.meta.motors_source = "RCOU Ch1-Ch4 (test)";
  write_dataset(dir_, ds);
  EXPECT_CONTAINS(test::read_file(dir_ / "meta.json"), "\"motors\"");
  const Dataset back = load_dataset(dir_);
  expect_identical(ds, back);
  ASSERT_EQ(back.meta.motors.on_s.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_SAME_BITS(back.meta.motors.on_s[i].first, ds.meta.motors.on_s[i].first);
    EXPECT_SAME_BITS(back.meta.motors.on_s[i].second, ds.meta.motors.on_s[i].second);
  }
  EXPECT_EQ(back.meta.motors_source, ds.meta.motors_source);
  // Without one, meta.json says nothing of motors (datasets written before read as they were).
  ds.meta.motors = {};
  write_dataset(dir_, ds);
  EXPECT_EQ(test::read_file(dir_ / "meta.json").find("motors"), std::string::npos);
  EXPECT_TRUE(load_dataset(dir_).meta.motors.empty());
}

TEST_F(DatasetTest, RoundTripIsBitIdenticalWithoutOptionalParts) {
  const Dataset ds = make_dataset(false, false, false);
  write_dataset(dir_, ds);
  EXPECT_EQ(entries(dir_), (std::vector<std::string>{"gnss.csv", "imu.csv", "meta.json"}));
  const std::string meta = test::read_file(dir_ / "meta.json");
  EXPECT_EQ(meta.find("injected"), std::string::npos);
  EXPECT_EQ(meta.find("noise"), std::string::npos);
  const Dataset back = load_dataset(dir_);
  EXPECT_TRUE(back.truth.empty());
  EXPECT_FALSE(back.meta.injected.has_value());
  EXPECT_FALSE(back.meta.noise.has_value());
  expect_identical(ds, back);
}

TEST_F(DatasetTest, RoundTripOfArbitraryRadiansIsWithinOneUlpThenExact) {
  // Radian values not made from degrees: some have no double in degrees that maps back
  // exactly; they come back within 1 ulp, and a second round trip is exact. Yaw comes back
  // in [0, 2 pi).
  Dataset ds = make_dataset(true, false, false);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (auto& t : ds.truth) {
    t.lat_rad = u(rng);
    t.lon_rad = 2 * u(rng);
    t.attitude.roll_rad = u(rng);
    t.attitude.yaw_rad = 2 * u(rng);
  }
  write_dataset(dir_, ds);
  const Dataset once = load_dataset(dir_);
  for (std::size_t i = 0; i < ds.truth.size(); ++i) {
    const TruthSample &a = ds.truth[i], &b = once.truth[i];
    EXPECT_LE(std::fabs(a.lat_rad - b.lat_rad),
              std::fabs(std::nextafter(a.lat_rad, 9) - a.lat_rad));
    EXPECT_LE(std::fabs(a.lon_rad - b.lon_rad),
              std::fabs(std::nextafter(a.lon_rad, 9) - a.lon_rad));
    EXPECT_LE(std::fabs(a.attitude.roll_rad - b.attitude.roll_rad),
              std::fabs(std::nextafter(a.attitude.roll_rad, 9) - a.attitude.roll_rad));
    EXPECT_GE(b.attitude.yaw_rad, 0.0);
    EXPECT_LT(b.attitude.yaw_rad, 2 * kPi);
    EXPECT_NEAR(wrap_pi(b.attitude.yaw_rad - a.attitude.yaw_rad), 0.0, 1e-14);
  }
  write_dataset(dir_, once);
  expect_identical(once, load_dataset(dir_));
}

TEST_F(DatasetTest, CrlfFilesLoad) {
  write_valid();
  const Dataset expected = load_dataset(dir_);
  for (const char* name : {"imu.csv", "gnss.csv", "truth.csv", "meta.json"}) {
    std::string crlf;
    for (const auto& l : split_lines(test::read_file(dir_ / name))) crlf += l + "\r\n";
    test::write_file(dir_ / name, crlf);
  }
  ASSERT_NE(test::read_file(dir_ / "imu.csv").find("\r\n"), std::string::npos);
  expect_identical(expected, load_dataset(dir_));
}

TEST_F(DatasetTest, ToleratesBomTrailingBlanksPaddingExtraFilesAndUnknownMetaKeys) {
  write_valid();
  const Dataset expected = load_dataset(dir_);
  test::write_file(dir_ / "imu.csv",
                   "\xEF\xBB\xBF" + test::read_file(dir_ / "imu.csv") + "\n  \n\n");
  replace_line(dir_ / "gnss.csv", 1, "t_s, lat_deg, lon_deg, h_m, vE_mps, vN_mps, vU_mps  ");
  test::write_file(dir_ / "README.txt", "extra file\n");
  std::string meta = test::read_file(dir_ / "meta.json");
  meta.insert(meta.find('{') + 1, "\"comment\": \"made by hand\", \"extra\": [1, 2],");
  test::write_file(dir_ / "meta.json", meta);
  expect_identical(expected, load_dataset(dir_));
}

TEST_F(DatasetTest, RecordedRowsAndDigestCatchCutsAndEditsOfWhatInsidWrote) {
  write_valid();
  const nlohmann::json meta = nlohmann::json::parse(test::read_file(dir_ / "meta.json"));
  ASSERT_EQ(meta["files"]["imu.csv"]["rows"].get<std::size_t>(), load_dataset(dir_).imu.size());
  const std::string imu = test::read_file(dir_ / "imu.csv");

  // Cut at a line boundary: every other check passes (a shorter flight), the count does not.
  auto lines = split_lines(imu);
  const std::size_t rows = lines.size() - 1;
  lines.resize(lines.size() - 5);
  test::write_file(dir_ / "imu.csv", join_lines(lines));
  std::string msg = load_error();
  EXPECT_CONTAINS(msg, "imu.csv: holds " + std::to_string(rows - 5) + " data rows");
  EXPECT_CONTAINS(msg, "files.imu.csv.rows) records " + std::to_string(rows));

  // One value changed in its last digit: rows agree, the digest does not.
  lines = split_lines(imu);
  std::string& row = lines[7];
  const auto last = row.find_last_of("0123456789");
  row[last] = row[last] == '1' ? '2' : '1';
  test::write_file(dir_ / "gnss.csv", test::read_file(dir_ / "gnss.csv"));  // untouched
  test::write_file(dir_ / "imu.csv", join_lines(lines));
  msg = load_error();
  EXPECT_CONTAINS(msg, "imu.csv: its values differ");
  EXPECT_CONTAINS(msg, "files.imu.csv.sha256");

  // The same file with the record removed is accepted as a hand-made dataset.
  forget_recorded_files();
  EXPECT_NO_THROW(load_dataset(dir_));
}

TEST_F(DatasetTest, MetaKeyGivenTwiceIsAnError) {
  write_valid();
  std::string meta = test::read_file(dir_ / "meta.json");
  meta.insert(meta.find('{') + 1, "\"align_s\": 5,");
  test::write_file(dir_ / "meta.json", meta);
  const std::string msg = load_error();
  EXPECT_EQ(msg, dir_.string() +
                     ": meta.json: align_s: key given twice in one object (JSON objects must not "
                     "repeat a key)");
}

// ---- malformed input: one test each ---------------------------------------------------------

TEST_F(DatasetTest, MissingDirectoryIsAnError) {
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, dir_.string());
  EXPECT_CONTAINS(msg, "does not exist");
}

TEST_F(DatasetTest, MissingFileIsAnError) {
  write_valid();
  fs::remove(dir_ / "imu.csv");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, dir_.string());
  EXPECT_CONTAINS(msg, "missing file imu.csv");
}

TEST_F(DatasetTest, EmptyFileIsAnError) {
  write_valid();
  test::write_file(dir_ / "gnss.csv", "");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, dir_.string() + ": gnss.csv line 1: empty file");
  EXPECT_CONTAINS(msg, "t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps");
}

TEST_F(DatasetTest, WrongHeaderIsAnErrorShowingTheExpectedHeader) {
  write_valid();
  replace_line(dir_ / "imu.csv", 1,
               "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,ax,dv_y_mps,dv_z_mps");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, dir_.string() + ": imu.csv line 1, column dv_x_mps: missing column");
  EXPECT_CONTAINS(msg,
                  "expected header 't_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,"
                  "dv_y_mps,dv_z_mps'");
}

TEST_F(DatasetTest, ColumnsOutOfOrderAreAnError) {
  write_valid();
  replace_line(dir_ / "gnss.csv", 1, "t_s,lon_deg,lat_deg,h_m,vE_mps,vN_mps,vU_mps");
  EXPECT_CONTAINS(load_error(), "gnss.csv line 1, column lat_deg: column out of order");
}

TEST_F(DatasetTest, MissingColumnIsAnError) {
  write_valid();
  // Drop vU_mps from the header and from every row.
  auto lines = split_lines(test::read_file(dir_ / "gnss.csv"));
  for (auto& l : lines) l = l.substr(0, l.rfind(','));
  test::write_file(dir_ / "gnss.csv", join_lines(lines));
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "gnss.csv line 1, column vU_mps: missing column");
}

TEST_F(DatasetTest, UnknownExtraColumnIsAnError) {
  write_valid();
  auto lines = split_lines(test::read_file(dir_ / "imu.csv"));
  lines[0] += ",temp_c";
  for (std::size_t i = 1; i < lines.size(); ++i) lines[i] += ",20";
  test::write_file(dir_ / "imu.csv", join_lines(lines));
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "imu.csv line 1, column temp_c: unknown column");
  EXPECT_CONTAINS(msg, "expected header 't_s,dtheta_x_rad");
}

TEST_F(DatasetTest, NanValueIsAnError) {
  write_valid();
  replace_line(dir_ / "imu.csv", 5, "0.03,1e-7,2e-7,3e-7,nan,0.001,-0.098");
  EXPECT_CONTAINS(load_error(), dir_.string() +
                                    ": imu.csv line 5, column dv_x_mps: expected a finite "
                                    "number, got 'nan'");
}

TEST_F(DatasetTest, InfValueIsAnError) {
  write_valid();
  replace_line(dir_ / "truth.csv", 3, "0.1,40,116,50,0,0,0,0,0,-inf");
  EXPECT_CONTAINS(load_error(),
                  "truth.csv line 3, column yaw_deg: expected a finite number, got '-inf'");
}

TEST_F(DatasetTest, NotANumberIsAnError) {
  write_valid();
  replace_line(dir_ / "gnss.csv", 4, "0.2,40.068,116.2x,50,0,0,0");
  EXPECT_CONTAINS(load_error(), "gnss.csv line 4, column lon_deg: expected a number, got '116.2x'");
  replace_line(dir_ / "gnss.csv", 4, "0.2,40.068,116.2,,0,0,0");
  EXPECT_CONTAINS(load_error(), "gnss.csv line 4, column h_m: empty field");
}

TEST_F(DatasetTest, TruncatedRowIsAnError) {
  write_valid();
  replace_line(dir_ / "imu.csv", 7, "0.05,1e-7,2e-7,3e-7,0.001");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg,
                  "imu.csv line 7, column dv_y_mps: truncated row, expected 7 "
                  "fields");
  EXPECT_CONTAINS(msg, "got 5");
}

TEST_F(DatasetTest, TooManyFieldsIsAnError) {
  write_valid();
  replace_line(dir_ / "imu.csv", 9, "0.07,1e-7,2e-7,3e-7,0.001,0.001,-0.098,5,6");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "imu.csv line 9: too many fields, expected 7");
  EXPECT_CONTAINS(msg, "got 9");
}

TEST_F(DatasetTest, BlankLineInTheMiddleIsAnError) {
  write_valid();
  replace_line(dir_ / "gnss.csv", 6, "");
  EXPECT_CONTAINS(load_error(), "gnss.csv line 6: empty line");
}

TEST_F(DatasetTest, NonMonotonicTimeIsAnError) {
  write_valid();
  replace_line(dir_ / "gnss.csv", 6, "0.35,40.068,116.2,50,0,0,0");  // line 5 has t = 0.3
  replace_line(dir_ / "gnss.csv", 7, "0.32,40.068,116.2,50,0,0,0");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg,
                  "gnss.csv line 7, column t_s: time 0.32 is before the time 0.35 "
                  "on line 6");
}

TEST_F(DatasetTest, RepeatedTimeIsAnError) {
  write_valid();
  replace_line(dir_ / "truth.csv", 4, "0.1,40,116,50,0,0,0,0,0,0");  // line 3 has t = 0.1
  EXPECT_CONTAINS(load_error(),
                  "truth.csv line 4, column t_s: time 0.1 repeats the time "
                  "0.1 on line 3");
}

TEST_F(DatasetTest, MissingMetaFieldIsAnError) {
  write_valid();
  std::string meta = test::read_file(dir_ / "meta.json");
  const std::size_t at = meta.find("\"g_eq_mps2\"");
  ASSERT_NE(at, std::string::npos);
  meta.replace(at, 2, "\"x");  // rename the key
  test::write_file(dir_ / "meta.json", meta);
  // The misspelt key is named (before the one it replaces is missed), with the valid ones.
  EXPECT_EQ(load_error(), dir_.string() +
                              ": meta.json: earth.x_eq_mps2: unknown key (valid keys: a_m, f, "
                              "omega_ie_rad_s, g_eq_mps2)");
  // Without it: missing.
  nlohmann::json j = nlohmann::json::parse(test::read_file(dir_ / "meta.json"));
  j["earth"].erase("x_eq_mps2");
  test::write_file(dir_ / "meta.json", j.dump(2));
  EXPECT_EQ(load_error(),
            dir_.string() + ": meta.json: earth.g_eq_mps2: missing, expected a finite number");
}

TEST_F(DatasetTest, UnknownMetaKeyInABlockIsNamedWithTheValidOnes) {
  // The blocks insid defines are closed (the top level is open: the test above).
  write_valid();
  nlohmann::json j = nlohmann::json::parse(test::read_file(dir_ / "meta.json"));
  j["initial"]["lat"] = 40.0;
  test::write_file(dir_ / "meta.json", j.dump(2));
  EXPECT_EQ(load_error(), dir_.string() +
                              ": meta.json: initial.lat: unknown key (valid keys: t_s, lat_deg, "
                              "lon_deg, h_m, vE_mps, vN_mps, vU_mps, roll_deg, pitch_deg, "
                              "yaw_deg)");
}

TEST_F(DatasetTest, BadJsonIsAnErrorWithPosition) {
  write_valid();
  test::write_file(dir_ / "meta.json",
                   "{\n  \"format\": \"insid-dataset/1\",\n  \"imu_rate_hz\": 100,,\n}\n");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "meta.json: not valid JSON");
  EXPECT_CONTAINS(msg, "line 3");
  EXPECT_CONTAINS(msg, "column");
}

TEST_F(DatasetTest, WrongTypeInMetaIsAnError) {
  write_valid();
  std::string meta = test::read_file(dir_ / "meta.json");
  const std::size_t at = meta.find("\"align_s\": ");
  ASSERT_NE(at, std::string::npos);
  meta.replace(at, meta.find(',', at) - at, "\"align_s\": \"10\"");
  test::write_file(dir_ / "meta.json", meta);
  EXPECT_EQ(load_error(), dir_.string() +
                              ": meta.json: align_s: expected a finite number, found a string "
                              "\"10\"");
}

TEST_F(DatasetTest, WrongFormatIsAnError) {
  write_valid();
  std::string meta = test::read_file(dir_ / "meta.json");
  meta.replace(meta.find("insid-dataset/1"), 15, "insid-dataset/3");
  test::write_file(dir_ / "meta.json", meta);
  EXPECT_CONTAINS(load_error(),
                  "meta.json: format: expected \"insid-dataset/1\" or \"insid-dataset/2\", "
                  "found a string \"insid-dataset/3\"");
}

// insid-dataset/2: measured timing. Jittery steps load; the declared rate must match the median
// step; a step beyond 1 s is refused; gaps are listed; an unknown initial attitude is null.
TEST_F(DatasetTest, Version2AcceptsJitteryStepsAndListsGaps) {
  Dataset ds = make_dataset(false, false, false);
  ds.meta.format = DatasetFormat::kV2;
  ds.meta.initial_attitude_known = false;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  const double dt = 1.0 / ds.meta.imu_rate_hz;
  for (std::size_t i = 1; i + 1 < ds.imu.size(); ++i) ds.imu[i].t_s += jitter(rng) * 0.5 * dt;
  ds.imu.erase(ds.imu.begin() + 50, ds.imu.begin() + 55);  // a gap of 6 steps
  write_dataset(dir_, ds);
  const std::string meta = test::read_file(dir_ / "meta.json");
  EXPECT_CONTAINS(meta, "\"format\": \"insid-dataset/2\"");
  EXPECT_CONTAINS(meta, "\"roll_deg\": null");
  const Dataset back = load_dataset(dir_);
  EXPECT_FALSE(back.meta.initial_attitude_known);
  const std::vector<ImuGap> gaps = imu_gaps(back);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].line, 52u);  // row index 50 (after the gap) is on line 52
  EXPECT_NEAR(gaps[0].dt_s, 6 * dt, 0.4 * dt);
  // The same data as /1 are refused by the 1 % step rule.
  ds.meta.format = DatasetFormat::kV1;
  ds.meta.initial_attitude_known = true;
  EXPECT_THROW(validate_dataset(ds), DatasetError);
  // A declared rate the median step contradicts, and a step beyond 1 s.
  ds.meta.format = DatasetFormat::kV2;
  ds.meta.imu_rate_hz *= 1.2;
  try {
    validate_dataset(ds);
    ADD_FAILURE();
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(std::string(e.what()), "disagrees with the median IMU step");
  }
  ds.meta.imu_rate_hz /= 1.2;
  for (std::size_t i = 100; i < ds.imu.size(); ++i) ds.imu[i].t_s += 1.5;
  try {
    validate_dataset(ds);
    ADD_FAILURE();
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(std::string(e.what()), "imu.csv line 102, column t_s: IMU gap of");
  }
}

TEST_F(DatasetTest, UnknownInjectedEffectIsAnError) {
  Dataset ds = make_dataset(false, true, false);
  write_dataset(dir_, ds);
  std::string meta = test::read_file(dir_ / "meta.json");
  meta.replace(meta.find("\"accel_bias_x\""), 14, "\"accel_bais_x\"");
  test::write_file(dir_ / "meta.json", meta);
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "meta.json: injected.accel_bais_x: unknown effect name");
  EXPECT_CONTAINS(msg, "gyro_bias_y");  // lists the catalogue

  ds.meta.injected->emplace("no_such_effect", 1.0);
  EXPECT_THROW(validate_dataset(ds), DatasetError);
}

TEST_F(DatasetTest, IrregularImuRateIsAnError) {
  write_valid();
  // Line 12 holds t = 0.10; move it to 0.1015 (a 15 ms step from 0.09, 1.5x the nominal).
  replace_line(dir_ / "imu.csv", 12, "0.1015,1e-7,2e-7,3e-7,0.001,0.001,-0.098");
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "imu.csv line 12, column t_s: IMU step");
  EXPECT_CONTAINS(msg, "not within 1% of 1/imu_rate_hz = 0.01 s");
}

TEST_F(DatasetTest, GnssNotCoveringTheStartIsAnError) {
  Dataset ds = make_dataset(false, false, false);
  ds.gnss.erase(ds.gnss.begin(), ds.gnss.begin() + 101);  // now starts at 10.1 s > 0 + 10 s
  try {
    validate_dataset(ds);
    FAIL() << "no error";
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(e.what(), "gnss.csv line 2, column t_s: GNSS does not cover the start");
    EXPECT_CONTAINS(e.what(), "uncovered: [10, 10.1) s");
  }
}

TEST_F(DatasetTest, GnssNotCoveringTheEndIsAnError) {
  write_valid(false);
  forget_recorded_files();
  auto lines = split_lines(test::read_file(dir_ / "gnss.csv"));
  lines.resize(lines.size() - 1);  // last GNSS at 29.9 s, IMU to 30 s: still covered
  test::write_file(dir_ / "gnss.csv", join_lines(lines));
  EXPECT_NO_THROW(load_dataset(dir_));
  lines.resize(lines.size() - 1);  // last GNSS at 29.8 s: 0.2 s > 0.15 s uncovered
  test::write_file(dir_ / "gnss.csv", join_lines(lines));
  const std::string msg = load_error();
  EXPECT_CONTAINS(msg, "gnss.csv line " + std::to_string(lines.size()) +
                           ", column t_s: GNSS does not cover the end");
  EXPECT_CONTAINS(msg, "uncovered: (29.8, 30] s");
}

TEST_F(DatasetTest, ValidateRejectsBadInMemoryDatasets) {
  auto message = [](const Dataset& ds) -> std::string {
    try {
      validate_dataset(ds);
    } catch (const DatasetError& e) {
      return e.what();
    }
    return "(no error)";
  };
  const Dataset good = make_dataset(true, true, true);
  EXPECT_NO_THROW(validate_dataset(good));

  Dataset ds = good;
  ds.meta.align_s = 30.0;
  EXPECT_CONTAINS(message(ds), "field \"align_s\" = 30 s must be shorter than the IMU");
  ds = good;
  ds.meta.align_s = -1.0;
  EXPECT_CONTAINS(message(ds), "field \"align_s\" must be >= 0");
  ds = good;
  ds.meta.imu_rate_hz = 0.0;
  EXPECT_CONTAINS(message(ds), "field \"imu_rate_hz\" must be > 0");
  ds = good;
  ds.meta.gnss_rate_hz = -10.0;
  EXPECT_CONTAINS(message(ds), "field \"gnss_rate_hz\" must be > 0");
  ds = good;
  ds.meta.earth.g_eq_mps2 = 1.0;
  EXPECT_CONTAINS(message(ds), "meta.json: invalid Earth model: earth.g_eq_mps2");
  ds = good;
  ds.imu[3].dv_b_mps.y() = std::nan("");
  EXPECT_CONTAINS(message(ds), "imu.csv line 5, column dv_y_mps: expected a finite");
  ds = good;
  ds.gnss[2].lat_rad = 1.6;
  EXPECT_CONTAINS(message(ds), "gnss.csv line 4, column lat_deg: latitude");
  ds = good;
  ds.meta.initial.lat_rad = -kPi / 2;
  EXPECT_CONTAINS(message(ds), "field \"initial.lat_deg\"");
  ds = good;
  ds.imu.resize(1);
  EXPECT_CONTAINS(message(ds), "imu.csv: need at least 2 data rows, got 1");
  ds = good;
  ds.gnss.resize(1);
  EXPECT_CONTAINS(message(ds), "gnss.csv: need at least 2 data rows, got 1");
  ds = good;
  ds.meta.noise->arw_deg_rth = -1.0;
  EXPECT_CONTAINS(message(ds), "field \"noise.arw_deg_rth\" must be a finite number >= 0");
  ds = good;
  ds.truth[5].t_s = ds.truth[4].t_s;
  EXPECT_CONTAINS(message(ds), "truth.csv line 7, column t_s: time");
}

// ---- writing --------------------------------------------------------------------------------

TEST_F(DatasetTest, UnwritableLocationIsAnErrorAndLeavesNothingBehind) {
  // (Tests may run as root, so use a path under a regular file rather than permissions.)
  test::write_file(root_ / "plain_file", "x");
  const Dataset ds = make_dataset(false, false, false);
  for (const fs::path& target :
       {root_ / "plain_file" / "ds", root_ / "plain_file" / "a" / "ds", root_ / "plain_file"}) {
    try {
      write_dataset(target, ds);
      ADD_FAILURE() << "no error for " << target;
    } catch (const DatasetError& e) {
      EXPECT_CONTAINS(e.what(), "cannot write dataset '" + target.string() + "'");
    }
    EXPECT_EQ(entries(root_), std::vector<std::string>{"plain_file"});
    EXPECT_EQ(test::read_file(root_ / "plain_file"), "x");
  }
  // Under /proc nothing can be created, even by root.
  EXPECT_THROW(write_dataset("/proc/insid_dataset_test/ds", ds), DatasetError);
  EXPECT_FALSE(fs::exists("/proc/insid_dataset_test"));
}

TEST_F(DatasetTest, WriteRefusesAnInvalidDatasetAndWritesNothing) {
  Dataset ds = make_dataset(false, false, false);
  ds.imu[10].t_s = ds.imu[9].t_s;
  try {
    write_dataset(dir_, ds);
    FAIL() << "no error";
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(e.what(), "invalid dataset: imu.csv line 12, column t_s");
  }
  EXPECT_TRUE(entries(root_).empty());
}

TEST_F(DatasetTest, WriteOverAnExistingDatasetReplacesIt) {
  write_valid(true);
  write_file_atomic(dir_ / "insid-optimum-cache.json", "{}");  // as identify writes it
  const Dataset fresh = make_dataset(false, false, true, 2001);
  write_dataset(dir_, fresh);
  // The old truth.csv and the cache went with the old dataset (both are insid's own).
  EXPECT_EQ(entries(dir_), (std::vector<std::string>{"gnss.csv", "imu.csv", "meta.json"}));
  expect_identical(fresh, load_dataset(dir_));
  EXPECT_EQ(entries(root_), std::vector<std::string>{"ds"});
  // A trailing separator names the same directory; missing parents are created.
  write_dataset(dir_.string() + "/", fresh);
  EXPECT_EQ(entries(root_), std::vector<std::string>{"ds"});
  write_dataset(root_ / "a" / "b" / "ds", fresh);
  expect_identical(fresh, load_dataset(root_ / "a" / "b" / "ds"));
}

TEST_F(DatasetTest, WriteNeverDeletesFilesItDidNotWrite) {
  const Dataset fresh = make_dataset(false, false, true, 2001);
  // A user's project directory: refused, untouched.
  const fs::path proj = root_ / "proj";
  fs::create_directories(proj / "src");
  test::write_file(proj / "src" / "code.c", "int main;");
  try {
    write_dataset(proj, fresh);
    FAIL() << "no error";
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(e.what(), "is not empty and not an insid dataset: it holds 'src'");
    EXPECT_CONTAINS(e.what(), "--force");
  }
  EXPECT_EQ(entries(proj), std::vector<std::string>{"src"});
  EXPECT_EQ(test::read_file(proj / "src" / "code.c"), "int main;");
  // A dataset directory with a user's note in it: refused too (the note would go).
  write_valid(true);
  test::write_file(dir_ / "notes.txt", "mine");
  EXPECT_THROW(write_dataset(dir_, fresh), DatasetError);
  EXPECT_EQ(test::read_file(dir_ / "notes.txt"), "mine");
  // A meta.json of another format is not an insid dataset.
  const fs::path other = root_ / "other";
  fs::create_directories(other);
  test::write_file(other / "meta.json", R"({"format": "somebody-else/2"})");
  EXPECT_THROW(write_dataset(other, fresh), DatasetError);
  EXPECT_EQ(test::read_file(other / "meta.json"), R"({"format": "somebody-else/2"})");

  // --force adds the dataset's files and keeps the rest.
  DatasetWriteOptions force;
  force.into_foreign_directory = true;
  write_dataset(proj, fresh, force);
  EXPECT_EQ(entries(proj), (std::vector<std::string>{"gnss.csv", "imu.csv", "meta.json", "src"}));
  EXPECT_EQ(test::read_file(proj / "src" / "code.c"), "int main;");
  expect_identical(fresh, load_dataset(proj));
  // ... but refuses to leave a stale truth.csv beside a dataset that has none.
  write_dataset(dir_, make_dataset(true, false, true, 2001), force);
  EXPECT_TRUE(fs::exists(dir_ / "truth.csv"));
  try {
    write_dataset(dir_, fresh, force);
    FAIL() << "no error";
  } catch (const DatasetError& e) {
    EXPECT_CONTAINS(e.what(), "it holds 'truth.csv'");
  }
  EXPECT_EQ(test::read_file(dir_ / "notes.txt"), "mine");
}

TEST_F(DatasetTest, WriteRefusesTheWorkingDirectoryAndItsParents) {
  write_valid(false);  // the working directory is an insid dataset
  const fs::path cwd = fs::current_path();
  fs::current_path(dir_);
  const Dataset fresh = make_dataset(false, false, true, 2001);
  for (const fs::path& target : {fs::path("."), fs::path(".."), dir_}) {
    try {
      write_dataset(target, fresh);
      ADD_FAILURE() << "no error for " << target;
    } catch (const DatasetError& e) {
      EXPECT_TRUE(std::string(e.what()).find("current directory") != std::string::npos ||
                  std::string(e.what()).find("not empty") != std::string::npos)
          << e.what();
    }
  }
  EXPECT_TRUE(fs::exists(dir_ / "imu.csv"));
  fs::current_path(cwd);
}

TEST_F(DatasetTest, WriteFileAtomicWritesReplacesAndFailsCleanly) {
  const fs::path p = root_ / "out.json";
  write_file_atomic(p, "first\n");
  EXPECT_EQ(test::read_file(p), "first\n");
  write_file_atomic(p, "second\n");
  EXPECT_EQ(test::read_file(p), "second\n");
  EXPECT_EQ(entries(root_), std::vector<std::string>{"out.json"});
  try {
    write_file_atomic(root_ / "out.json" / "x.json", "x");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot write '" + (root_ / "out.json" / "x.json").string());
    EXPECT_CONTAINS(e.what(), "Not a directory");
  }
  fs::create_directory(root_ / "adir");
  EXPECT_THROW(write_file_atomic(root_ / "adir", "x"), std::runtime_error);  // a directory
  EXPECT_EQ(entries(root_), (std::vector<std::string>{"adir", "out.json"}));
}

TEST_F(DatasetTest, WriteFileAtomicWritesIntoADeviceWithoutReplacingIt) {
  // `--summary /dev/null` must not put a regular file in place of /dev/null. The test uses its
  // own node of the same device (1, 3), so a regression cannot break the machine's /dev/null.
  const fs::path null_device = root_ / "null";
  if (::mknod(null_device.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0)
    GTEST_SKIP() << "cannot create a device node here (needs root)";
  write_file_atomic(null_device, "{}\n");
  EXPECT_TRUE(fs::is_character_file(null_device));
  EXPECT_EQ(entries(root_), std::vector<std::string>{"null"});  // no temporary left
}

// Manual timing (not run by default): one hour at 100 Hz.
TEST_F(DatasetTest, DISABLED_LoadTimeFor360kImuRows) {
  const Dataset ds = make_dataset(false, false, false, 360001);
  Dataset big = ds;
  big.gnss.clear();
  for (int i = 0; i <= 36000; ++i) {
    GnssSample g;
    g.t_s = i / 10.0;
    g.lat_rad = 0.7;
    big.gnss.push_back(g);
  }
  write_dataset(dir_, big);
  const auto t0 = std::chrono::steady_clock::now();
  const Dataset back = load_dataset(dir_);
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("load_dataset: %zu IMU rows (%.1f MB) + %zu GNSS rows in %.3f s\n", back.imu.size(),
              fs::file_size(dir_ / "imu.csv") / 1e6, back.gnss.size(),
              std::chrono::duration<double>(t1 - t0).count());
}

}  // namespace
}  // namespace insid
