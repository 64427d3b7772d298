// `insid import ardupilot` end to end through the insid binary on the shared ArduPilot log
// (../shared/data/ardupilot-copter/log171.bin, read in place; copies cut or corrupted only in a
// temporary directory), then `insid navigate` on the dataset. Skips where the log is absent.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <string>
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

const fs::path kLog = fs::path(INSID_SHARED_DATA) / "ardupilot-copter" / "log171.bin";
constexpr const char* kNoLog =
    "../shared/data/ardupilot-copter/log171.bin is absent (tests that need the shared real data "
    "skip without it)";

// `insid import ardupilot` of the shared log cut to boot time 74.7-215 s (after the 2.0 s
// logging gap, before Acro and the flip) into `ds`.
Outcome import_flight_window(const fs::path& ds) {
  return insid("import ardupilot " + kLog.string() + " --t-start 74.7 --t-end 215 --out " +
               ds.string());
}

// Options are checked before any file is read (exit 2, the README's table); no shared data needed.
TEST(ArduPilotCli, UsageErrorsBeforeReading) {
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const std::string out = " --out " + (tmp.path / "ds").string();
  Outcome o = insid("import ardupilot " + (tmp.path / "none.bin").string() + " --imu IMU4" + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--imu 'IMU4': must be IMU, IMU2 or IMU3"), std::string::npos)
      << o.output;
  o = insid("import ardupilot " + (tmp.path / "none.bin").string() + " --t-start 100 --t-end 50" +
            out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--t-start 100 must be before --t-end 50"), std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "ds"));
}

// The whole log has a 2.0 s logging gap (boot 72.606-74.628 s): refused, naming where to cut.
// After it and before the flip (README: from ~239 s; Acro from 217.2 s) the import succeeds and
// navigate runs on it.
TEST(ArduPilotCli, ImportCutAndNavigate) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path refused = tmp.path / "refused";
  Outcome o = insid("import ardupilot " + kLog.string() + " --out " + refused.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("logging gap of 2.022 s after boot time 72.606 s"), std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--t-start 74.628"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(refused));

  const fs::path ds = tmp.path / "ds";
  o = import_flight_window(ds);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("IMU from IMU (the log has IMU (11916), IMU2 (11916), IMU3 (11916)"),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("aliases"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("GPS VZ is positive down (v_u = -VZ)"), std::string::npos) << o.output;
  std::ifstream in(ds / "provenance.json");
  const nlohmann::json prov = nlohmann::json::parse(in);
  EXPECT_EQ(prov.at("command"), "insid import ardupilot");
  EXPECT_TRUE(prov.at("gnss").at("vz_sign").at("down_positive").get<bool>());
  EXPECT_EQ(prov.at("clock").at("excluded"), 3);
  EXPECT_EQ(prov.at("options").at("imu"), "IMU");
  EXPECT_EQ(prov.at("sources").at(0).at("sha256").get<std::string>().substr(0, 8), "a4a3883f");

  // A multicopter's gyros cannot gyrocompass: heading from the GNSS course at take-off.
  o = insid("navigate --data " + ds.string() + " --initial-attitude level+heading --summary " +
            (tmp.path / "nav.json").string());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(fs::exists(tmp.path / "nav.json"));
}

// A copy cut at byte 1500000 imports what came before and names the offset; a copy whose IMU
// FMT record has an unknown type letter is refused naming the offset, and nothing is written.
TEST(ArduPilotCli, TruncatedAndCorruptedCopies) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const std::string bytes = test::read_file(kLog);
  ASSERT_GT(bytes.size(), 1500000u);
  test::write_file(tmp.path / "cut.bin", bytes.substr(0, 1500000));
  Outcome o = insid("import ardupilot " + (tmp.path / "cut.bin").string() +
                    " --t-start 74.7 --out " + (tmp.path / "cut").string());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("cut.bin: byte 1499984: the file ends inside a record of IMU"),
            std::string::npos)
      << o.output;
  EXPECT_TRUE(fs::exists(tmp.path / "cut" / "imu.csv"));

  std::string corrupted = bytes;
  ASSERT_EQ(corrupted.compare(276, 10, "IffffffIIf"), 0);
  corrupted[277] = 'X';
  test::write_file(tmp.path / "bad.bin", corrupted);
  o = insid("import ardupilot " + (tmp.path / "bad.bin").string() + " --out " +
            (tmp.path / "bad").string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("bad.bin: byte 267: FMT record for message id 131 (IMU)"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "bad"));
}

// 3 stray bytes inside a record in the middle of the log dropped 68 % of the IMU rows
// (the reader stopped at the first broken header). GIVEN the shared log with 3 bytes inserted
// 7 bytes into a record at its middle WHEN the flight window is imported THEN reading resumes
// on the next valid record: at most the damaged record and its neighbours are lost (6941 rows
// whole, at least 6938 here), the note names the byte where the damage starts and how much was
// skipped, and provenance.json counts it.
TEST(ArduPilotCli, StrayBytesMidLogAreSkippedToTheNextRecord) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const std::string bytes = test::read_file(kLog);
  // A record header near the middle, then 3 bytes inserted 7 bytes into that record.
  const std::size_t header = bytes.find("\xA3\x95", bytes.size() / 2);
  ASSERT_NE(header, std::string::npos);
  const std::size_t at = header + 7;
  test::write_file(tmp.path / "stray.bin", bytes.substr(0, at) + "\x01\x02\x03" + bytes.substr(at));
  const Outcome o = insid("import ardupilot " + (tmp.path / "stray.bin").string() +
                          " --t-start 74.7 --t-end 215 --out " + (tmp.path / "ds").string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("1 damaged place(s) in the log"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("reading resumed on the next valid record: byte "), std::string::npos)
      << o.output;
  std::ifstream prov_in(tmp.path / "ds" / "provenance.json");
  const nlohmann::json prov = nlohmann::json::parse(prov_in);
  EXPECT_EQ(prov["dataflash"]["skipped"]["places"], 1);
  const int rows = prov["imu"]["rows_used"].get<int>();
  std::cout << "IMU rows after 3 stray bytes: " << rows << " of 6941\n";
  EXPECT_GE(rows, 6938);
  EXPECT_FALSE(prov["dataflash"].contains("truncation"));
}

// One flipped bit in a GPS record's Week pulled the boot clock's first line fit off
// every other fix ("fewer than 2 fixes within 0.1 s of the fit"). GIVEN the shared log with the
// top bit of Week flipped in one GPS record mid-log WHEN imported THEN that fix is left out of
// the clock fit like a late one (one more than in the undamaged log) and the import completes
// with the same clock slope; the fix is dropped from the GNSS epochs, with a note.
TEST(ArduPilotCli, OneDamagedGpsWeekDoesNotBreakTheBootClock) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  std::string bytes = test::read_file(kLog);
  // The GPS message's id and the offset of its Week field, from its FMT record.
  std::size_t gps_fmt = std::string::npos;
  for (std::size_t q = bytes.find("\xA3\x95\x80"); q != std::string::npos && q < 20000;
       q = bytes.find("\xA3\x95\x80", q + 1))
    if (bytes.compare(q + 5, 4, std::string("GPS\0", 4)) == 0) gps_fmt = q;
  ASSERT_NE(gps_fmt, std::string::npos);
  const auto gps_id = static_cast<char>(bytes[gps_fmt + 3]);
  const std::string letters = bytes.substr(gps_fmt + 9, 16).c_str();
  const std::string columns = bytes.substr(gps_fmt + 25, 64).c_str();
  auto size_of = [](char c) -> std::size_t {
    switch (c) {
      case 'b':
      case 'B':
      case 'M':
        return 1;
      case 'h':
      case 'H':
      case 'c':
      case 'C':
        return 2;
      case 'i':
      case 'I':
      case 'e':
      case 'E':
      case 'L':
      case 'f':
      case 'n':
        return 4;
      case 'd':
      case 'q':
      case 'Q':
        return 8;
      case 'N':
        return 16;
      case 'Z':
        return 64;
      default:
        return 0;
    }
  };
  std::size_t week_offset = 3, field = 0;
  std::size_t start = 0;
  for (; field < letters.size(); ++field) {
    const std::size_t end = columns.find(',', start);
    if (columns.substr(start, end - start) == "Week") break;
    week_offset += size_of(letters[field]);
    start = end + 1;
  }
  ASSERT_LT(field, letters.size()) << columns;
  ASSERT_EQ(letters[field], 'H');
  const std::size_t record = bytes.find(std::string("\xA3\x95", 2) + gps_id, bytes.size() / 2);
  ASSERT_NE(record, std::string::npos);
  bytes[record + week_offset + 1] ^= static_cast<char>(0x80);  // Week + 32768
  test::write_file(tmp.path / "week.bin", bytes);
  const Outcome ok = import_flight_window(tmp.path / "whole");
  ASSERT_EQ(ok.status, 0) << ok.output;
  const Outcome o = insid("import ardupilot " + (tmp.path / "week.bin").string() +
                          " --t-start 74.7 --t-end 215 --out " + (tmp.path / "ds").string());
  ASSERT_EQ(o.status, 0) << o.output;
  auto clock_of = [](const fs::path& ds) {
    std::ifstream in(ds / "provenance.json");
    return nlohmann::json::parse(in)["clock"];
  };
  const nlohmann::json whole = clock_of(tmp.path / "whole"), damaged = clock_of(tmp.path / "ds");
  std::cout << "clock, whole: " << whole.dump() << "\nclock, damaged: " << damaged.dump() << "\n";
  EXPECT_EQ(damaged["excluded"].get<int>(), whole["excluded"].get<int>() + 1);
  // One fix fewer moves the slope by ~2.5e-8 (4 us over the flight); the old first fit put it
  // off by the damaged fix's 32768 weeks. 1e-6 is 0.15 ms over 150 s, the residuals are 7.7 ms.
  EXPECT_NEAR(damaged["slope"].get<double>(), whole["slope"].get<double>(), 1e-6);
  // The fix itself: dropped from the GNSS epochs with a note, the rest kept.
  EXPECT_NE(o.output.find("dropped 1 GPS fixes whose own time (Week, TimeMS) is more than 1 s off"),
            std::string::npos)
      << o.output;
}

// The real PX4 ULog whose sensor_combined was decimated by the logger to ~8.6 Hz (README of
// ../shared/data/px4-ulog-real): refused with the measured rate and the minimum, exit 1, nothing
// written; with --min-imu-rate-hz below its rate the rate is no longer the reason (the log then
// fails on its own static window, which starts moving at once: that message, not the rate's).
TEST(LowRateCli, EightHertzUlogIsRefusedNamingTheRateAndTheMinimum) {
  const fs::path log = fs::path(INSID_SHARED_DATA) / "px4-ulog-real" / "esc_status_log.ulg";
  if (!fs::exists(log))
    GTEST_SKIP() << "../shared/data/px4-ulog-real/esc_status_log.ulg is absent (tests that need "
                    "the shared real data skip without it)";
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path out = tmp.path / "ds";
  Outcome o = insid("import ulog " + log.string() + " --out " + out.string());
  EXPECT_EQ(o.status, 1) << o.output;
  // Python (the ULog's sensor_combined stamps): 341 messages, median step 104 ms, 8.6 Hz on
  // average over the span the GNSS covers.
  EXPECT_NE(o.output.find("esc_status_log.ulg, sensor_combined instance 0: IMU rate 9.62 Hz "
                          "(median step 104 ms; 8.61 Hz on average"),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("is below the 20 Hz insid accepts for strapdown integration"),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--min-imu-rate-hz R (R <= 9.62)"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out));
  o = insid("import ulog " + log.string() + " --min-imu-rate-hz 9 --out " + out.string());
  EXPECT_EQ(o.output.find("insid accepts for strapdown integration"), std::string::npos)
      << o.output;
}

// Flight phases of the shared copter log, against times read independently of the IMU and GPS
// rules (Python, struct.unpack on the FMT layouts, /usr/bin/python3, while writing this test):
// the four motor outputs (RCOU Ch1-4) all above 1100 from 82.864 s and above 1150 from 83.509 s;
// the barometer (BARO Alt) 1 m above its 70-83 s mean from 85.151 s; IMU2 and IMU3 (other
// physical sensors than the IMU the phases are found on) first above 4 g at 239.140 s; the
// autopilot's attitude (ATT Roll) beyond +-150 deg for good from 240.995 s. The suggested
// window starts after the 2.0 s logging gap (74.628 s) and ends 2 s before the crash.
TEST(ArduPilotCli, FlightPhasesMatchTimesReadFromOtherMessages) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path ds = tmp.path / "ds";
  Outcome o = import_flight_window(ds);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("  crash        239.14 s (impact)"), std::string::npos) << o.output;
  std::ifstream in(ds / "provenance.json");
  const nlohmann::json ph = nlohmann::json::parse(in).at("flight_phases");
  EXPECT_GE(ph.at("motors_on_boot_s").get<double>(), 82.864 - 0.5);
  EXPECT_LE(ph.at("motors_on_boot_s").get<double>(), 83.509 + 0.5);
  EXPECT_NEAR(ph.at("takeoff_boot_s").get<double>(), 85.151, 1.0);
  EXPECT_NEAR(ph.at("crash_boot_s").get<double>(), 239.140, 0.021);  // one 50 Hz step
  EXPECT_NEAR(ph.at("inverted_boot_s").get<double>(), 240.995, 1.0);
  EXPECT_EQ(ph.at("airborne").at("ended_by"), "crash");
  EXPECT_NEAR(ph.at("suggested_window_boot_s").at("t_start").get<double>(), 74.628, 1e-9);
  EXPECT_NEAR(ph.at("suggested_window_boot_s").at("t_end").get<double>(), 239.140 - 2.0, 0.021);
  // The log's own flight without the crash imports with the suggested window.
  o = insid("import ardupilot " + kLog.string() + " --t-start 74.628 --t-end 237.14 --out " +
            (tmp.path / "flight").string());
  EXPECT_EQ(o.status, 0) << o.output;
}

// The motor schedule (meta.json "motors") from RCOU: the first record with an output above
// 1100 us is at TimeMS 82864 (all four outputs 1117 us, read from the log; the armed idle before
// it, at 82844, is 1049 us, disarmed 1000 us), and the IMU's own motor-start detector (flight
// phases, from the vibration) puts it at 82.96 s: two sources, one instant. The schedule runs to
// the end of the cut (the last IMU row inside the GNSS span, before 215 s), and the detected
// static window ends before it.
TEST(ArduPilotCli, MotorScheduleFromRcouMatchesTheImuMotorStart) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path ds = tmp.path / "ds";
  const Outcome o = import_flight_window(ds);
  ASSERT_EQ(o.status, 0) << o.output;
  const nlohmann::json meta = test::read_json(ds / "meta.json");
  const nlohmann::json prov = test::read_json(ds / "provenance.json");
  ASSERT_TRUE(meta.contains("motors")) << o.output;
  const nlohmann::json& on = meta.at("motors").at("on_s");
  ASSERT_EQ(on.size(), 1u) << on.dump();
  // dataset t -> boot s: GPST = t + origin = gpst_at_boot_zero + slope * boot.
  const double origin = prov.at("time_origin_gpst_unix_s").get<double>();
  const double gpst0 = prov.at("clock").at("gpst_at_boot_zero_unix_s").get<double>();
  const double slope = prov.at("clock").at("slope").get<double>();
  const auto boot_of = [&](double t_s) { return (t_s + origin - gpst0) / slope; };
  EXPECT_NEAR(boot_of(on[0][0].get<double>()), 82.864, 2e-3) << on.dump();
  EXPECT_NEAR(boot_of(on[0][0].get<double>()),
              prov.at("flight_phases").at("motors_on_boot_s").get<double>(), 0.1);
  EXPECT_GT(boot_of(on[0][1].get<double>()), 214.8) << on.dump();
  EXPECT_LE(boot_of(on[0][1].get<double>()), 215.0) << on.dump();
  const double t0 = meta.at("initial").at("t_s").get<double>();
  EXPECT_LE(t0 + meta.at("align_s").get<double>(), on[0][0].get<double>());
  EXPECT_NE(o.output.find("motors running (RCOU Ch1-Ch4"), std::string::npos) << o.output;
}

// The autopilot EKF's bias estimates in meta.json, against values decoded by hand from the bytes
// of log171.bin: the last EKF1 record at or before boot 215 s is at byte 2513736 (a3 95 8c, then
// TimeMS 214979 = 0x000347c3); GX, GY, GZ are its int16 at bytes +37, +39, +41 = 20, 2, 6
// (FMT "IccCffffffccc": 3 + 4 + 2 + 2 + 2 + 6 x 4 = 37), i.e. 0.20, 0.02, 0.06 deg/s;
// the EKF2 record at byte 2513779 holds AZ1bias, AZ2bias as int8 at +8, +9 = 21, 41 cm/s^2
// (FMT "Ibbbcchhhhhh": Ratio at +7). A wrong scale (x1, x0.01 twice) or a swapped axis or IMU
// fails here. The test re-reads those bytes so that the offsets themselves are checked.
TEST(ArduPilotCli, AutopilotBiasesMatchBytesDecodedByHand) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  const std::string bytes = test::read_file(kLog);
  ASSERT_GT(bytes.size(), 2513790u);
  const auto i16 = [&](std::size_t at) {
    return static_cast<std::int16_t>(static_cast<unsigned char>(bytes[at]) |
                                     (static_cast<unsigned char>(bytes[at + 1]) << 8));
  };
  ASSERT_EQ(bytes.compare(2513736, 3, "\xA3\x95\x8C"), 0);
  ASSERT_EQ(bytes.compare(2513779, 3, "\xA3\x95\x8D"), 0);
  ASSERT_EQ(i16(2513736 + 37), 20);
  ASSERT_EQ(i16(2513736 + 39), 2);
  ASSERT_EQ(i16(2513736 + 41), 6);
  ASSERT_EQ(static_cast<std::int8_t>(bytes[2513779 + 8]), 21);
  ASSERT_EQ(static_cast<std::int8_t>(bytes[2513779 + 9]), 41);

  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path ds = tmp.path / "ds";
  const Outcome o = insid("import ardupilot " + kLog.string() +
                          " --t-start 74.7 --t-end 215 --out " + ds.string());
  ASSERT_EQ(o.status, 0) << o.output;
  std::ifstream in(ds / "meta.json");
  const nlohmann::json ap = nlohmann::json::parse(in).at("autopilot_estimates");
  constexpr double kCentiDegS = 0.01 * 3.14159265358979323846 / 180.0;  // rad/s
  std::map<std::string, double> want = {{"EKF1.GX", 20 * kCentiDegS},
                                        {"EKF1.GY", 2 * kCentiDegS},
                                        {"EKF1.GZ", 6 * kCentiDegS},
                                        {"EKF2.AZ1bias", 0.21},
                                        {"EKF2.AZ2bias", 0.41}};
  const std::map<std::string, std::string> effect = {{"EKF1.GX", "gyro_bias_x"},
                                                     {"EKF1.GY", "gyro_bias_y"},
                                                     {"EKF1.GZ", "gyro_bias_z"},
                                                     {"EKF2.AZ1bias", "accel_bias_z"},
                                                     {"EKF2.AZ2bias", "accel_bias_z"}};
  ASSERT_EQ(ap.at("estimates").size(), 5u);
  for (const nlohmann::json& e : ap.at("estimates")) {
    const std::string source = e.at("source");
    ASSERT_TRUE(want.count(source)) << source;
    EXPECT_NEAR(e.at("end_si").get<double>(), want.at(source), 1e-12) << source;
    EXPECT_EQ(e.at("effect"), effect.at(source)) << source;
    EXPECT_NEAR(e.at("end_boot_s").get<double>(), 214.979, 1e-9) << source;
    // EKF1's gyro biases belong to the mean of the first two gyros (NavEKF's dual-gyro mode),
    // EKF2's AZ1bias / AZ2bias to the first / second accelerometer.
    const std::string imu = source == "EKF2.AZ2bias"   ? "IMU2"
                            : source == "EKF2.AZ1bias" ? "IMU"
                                                       : "IMU+IMU2";
    EXPECT_EQ(e.at("imu"), imu) << source;
    EXPECT_EQ(e.at("applies_to_imported_imu").get<bool>(), source == "EKF2.AZ1bias") << source;
    EXPECT_GT(e.at("airborne_records").get<int>(), 1000) << source;
  }
  EXPECT_EQ(ap.at("imported_imu"), "IMU");
}

// identify on the imported copter flight puts insid's estimates next to the autopilot EKF's
// (meta.json autopilot_estimates): each compared value is the one the import recorded (the
// airborne mean, its scatter plus one logging step's rounding as its sd), insid's is the result's
// own estimate and sd; the EKF's gyro biases (the mean of IMU's and IMU2's gyros) and IMU2's
// accelerometer bias are listed as not compared.
TEST(ArduPilotCli, IdentifyShowsTheAutopilotEstimatesBesideInsids) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path ds = tmp.path / "ds";
  Outcome o = import_flight_window(ds);
  ASSERT_EQ(o.status, 0) << o.output;
  o = insid("identify --data " + ds.string() +
            " --algo ekf-rts --initial-attitude level+heading --window-s 20 --grade mems "
            "--estimate gyro_bias_x --estimate gyro_bias_y --estimate gyro_bias_z "
            "--estimate accel_bias_z --threads 1 --out " +
            (tmp.path / "r.json").string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("insid against the autopilot"), std::string::npos) << o.output;
  std::ifstream rin(tmp.path / "r.json");
  const nlohmann::json r = nlohmann::json::parse(rin);
  std::ifstream min(ds / "meta.json");
  const nlohmann::json ap = nlohmann::json::parse(min).at("autopilot_estimates");
  const nlohmann::json& cmp = r.at("autopilot_comparison");
  ASSERT_EQ(cmp.at("compared").size(), 1u);  // accel_bias_z of IMU (EKF2.AZ1bias)
  for (const nlohmann::json& c : cmp["compared"]) {
    const std::string name = c.at("name");
    const nlohmann::json* e = nullptr;
    for (const nlohmann::json& x : ap.at("estimates"))
      if (x.at("effect") == name && x.at("imu") == "IMU") e = &x;
    ASSERT_NE(e, nullptr) << name;
    EXPECT_EQ(c.at("autopilot_value_si").get<double>(), e->at("airborne_mean_si").get<double>());
    EXPECT_NEAR(c.at("autopilot_sd_si").get<double>(),
                std::hypot(e->at("airborne_sd_si").get<double>(),
                           e->at("resolution_si").get<double>() / std::sqrt(12.0)),
                1e-15);
    const nlohmann::json* p = nullptr;
    for (const nlohmann::json& x : r.at("parameters"))
      if (x.at("name") == name) p = &x;
    ASSERT_NE(p, nullptr) << name;
    EXPECT_EQ(c.at("insid_estimate_si").get<double>(), p->at("estimate").get<double>());
    EXPECT_EQ(c.at("insid_sd_si"), p->at("sd"));
    EXPECT_NEAR(c.at("difference_si").get<double>(),
                p->at("estimate").get<double>() - e->at("airborne_mean_si").get<double>(), 1e-15);
  }
  // The gyro biases of the two-gyro mean and IMU2's accelerometer are not the imported IMU's.
  ASSERT_EQ(cmp.at("not_compared").size(), 4u);
  std::vector<std::string> not_compared;
  for (const nlohmann::json& n : cmp["not_compared"]) {
    not_compared.push_back(n.at("autopilot"));
    EXPECT_NE(n.at("why").get<std::string>().find("not to the imported IMU"), std::string::npos)
        << n;
  }
  EXPECT_EQ(not_compared, (std::vector<std::string>{"EKF1.GX (IMU+IMU2)", "EKF1.GY (IMU+IMU2)",
                                                    "EKF1.GZ (IMU+IMU2)", "EKF2.AZ2bias (IMU2)"}));
}

}  // namespace
