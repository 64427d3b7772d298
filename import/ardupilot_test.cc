// The DataFlash reader and the ArduPilot import: synthetic records for every type
// letter and every refusal, and the shared real log (../shared/data/ardupilot-copter/log171.bin,
// read in place, never copied; the tests that need it skip where it is absent).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "import/ardupilot_import.h"
#include "import/dataflash.h"
#include "import/importer.h"
#include "model/earth.h"

namespace insid::importers {
namespace {
namespace fs = std::filesystem;

// A FMT record (89 bytes) defining message `id`.
std::string fmt_record(std::uint8_t id, std::uint8_t length, const std::string& name,
                       const std::string& letters, const std::string& labels) {
  std::string r = "\xA3\x95\x80";
  r += static_cast<char>(id);
  r += static_cast<char>(length);
  const auto fixed = [&](const std::string& s, std::size_t n) {
    std::string f = s.substr(0, n);
    f.resize(n, '\0');
    r += f;
  };
  fixed(name, 4);
  fixed(letters, 16);
  fixed(labels, 64);
  return r;
}

template <class T>
void put(std::string& r, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  r.append(b, sizeof v);
}

std::string fmt_of_fmt() {
  return fmt_record(128, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
}

// One record of every numeric letter, with the scaling ArduPilot documents.
TEST(DataFlash, DecodesEveryTypeLetter) {
  const std::string letters = "bBhHiIfdqQcCeELM";  // 16: FMT's Format field holds no more
  std::string log = fmt_of_fmt();
  // 1+1+2+2+4+4+4+8+8+8+2+2+4+4+4+1 = 59 bytes of payload
  log += fmt_record(200, 62, "ALL", letters, "b,B,h,H,i,I,f,d,q,Q,c,C,e,E,L,M");
  log += fmt_record(201, 3 + 4 + 16 + 64, "TXT", "nNZ", "n,N,Z");
  std::string r = "\xA3\x95\xC8";
  put<std::int8_t>(r, -5);
  put<std::uint8_t>(r, 250);
  put<std::int16_t>(r, -30000);
  put<std::uint16_t>(r, 60000);
  put<std::int32_t>(r, -2000000000);
  put<std::uint32_t>(r, 4000000000u);
  put<float>(r, 1.5f);
  put<double>(r, -2.25);
  put<std::int64_t>(r, -(std::int64_t{1} << 40));
  put<std::uint64_t>(r, std::uint64_t{1} << 50);
  put<std::int16_t>(r, -1234);         // c: -12.34
  put<std::uint16_t>(r, 65535);        // C: 655.35
  put<std::int32_t>(r, -123456);       // e: -1234.56
  put<std::uint32_t>(r, 4000000000u);  // E: 40000000.00
  put<std::int32_t>(r, -353623714);    // L: -35.3623714 deg
  put<std::uint8_t>(r, 5);             // M
  ASSERT_EQ(r.size(), 62u);
  log += r;
  const DataFlashFile f = DataFlashFile::parse(log, "all.bin");
  EXPECT_EQ(f.truncation(), "");
  EXPECT_EQ(f.count("ALL"), 1u);
  const auto rows = f.read(
      "ALL", {"b", "B", "h", "H", "i", "I", "f", "d", "q", "Q", "c", "C", "e", "E", "L", "M"});
  ASSERT_EQ(rows.size(), 1u);
  const std::vector<double> expected = {-5,
                                        250,
                                        -30000,
                                        60000,
                                        -2000000000,
                                        4000000000.0,
                                        1.5,
                                        -2.25,
                                        -1099511627776.0,
                                        1125899906842624.0,
                                        -12.34,
                                        655.35,
                                        -1234.56,
                                        40000000.0,
                                        -35.3623714,
                                        5};
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(rows[0][i], expected[i], std::fabs(expected[i]) * 1e-12) << letters[i];
  EXPECT_THROW(f.read("TXT", {"N"}), std::runtime_error);     // text, not a number
  EXPECT_THROW(f.read("ALL", {"nope"}), std::runtime_error);  // no such field
  EXPECT_THROW(f.read("NONE", {"b"}), std::runtime_error);    // no such message
}

std::string parse_error(const std::string& bytes) {
  try {
    DataFlashFile::parse(bytes, "x.bin");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(DataFlash, RefusesBadFormatsNamingTheOffset) {
  EXPECT_NE(parse_error("ULog\x01\x12").find("x.bin: byte 0: not an ArduPilot DataFlash log"),
            std::string::npos);
  const std::string head = fmt_of_fmt();  // 89 bytes: the next record starts at byte 89
  std::string e = parse_error(head + fmt_record(131, 11, "IMU", "IfX", "TimeMS,GyrX,GyrY"));
  EXPECT_NE(e.find("x.bin: byte 89: FMT record for message id 131 (IMU): field Format 'IfX': "
                   "unknown type letter 'X' for field GyrY"),
            std::string::npos)
      << e;
  e = parse_error(head + fmt_record(131, 12, "IMU", "If", "TimeMS,GyrX"));
  EXPECT_NE(e.find("byte 89: FMT record for message id 131 (IMU): field Length 12 disagrees"),
            std::string::npos)
      << e;
  e = parse_error(head + fmt_record(131, 11, "IMU", "If", "TimeMS"));
  EXPECT_NE(e.find("byte 89: FMT record for message id 131 (IMU): field Format 'If' has 2 type "
                   "letters but field Columns 'TimeMS' names 1"),
            std::string::npos)
      << e;
  e = parse_error(head + fmt_record(131, 11, "IMU", "If", "T,G") +
                  fmt_record(131, 7, "IMU", "I", "T"));
  EXPECT_NE(e.find("byte 178: FMT record for message id 131 (IMU): redefines message id 131"),
            std::string::npos)
      << e;
}

TEST(DataFlash, KeepsTheRecordsBeforeDamage) {
  std::string log = fmt_of_fmt() + fmt_record(131, 7, "T", "I", "TimeMS");
  std::string rec = "\xA3\x95\x83";
  put<std::uint32_t>(rec, 42);
  log += rec + rec;  // records at 178 and 185
  const DataFlashFile whole = DataFlashFile::parse(log, "x.bin");
  EXPECT_EQ(whole.count("T"), 2u);
  EXPECT_EQ(whole.truncation(), "");
  // Cut inside the second record, inside its header, and garbage in place of a header.
  for (const std::size_t cut : {std::size_t{190}, std::size_t{186}}) {
    const DataFlashFile f = DataFlashFile::parse(log.substr(0, cut), "x.bin");
    EXPECT_EQ(f.count("T"), 1u);
    EXPECT_NE(f.truncation().find("x.bin: byte 185: the file ends inside a"), std::string::npos)
        << f.truncation();
  }
  std::string garbage = log;
  garbage[185] = 'Z';
  const DataFlashFile g = DataFlashFile::parse(garbage, "x.bin");
  EXPECT_EQ(g.count("T"), 1u);
  EXPECT_NE(g.truncation().find("x.bin: byte 185: no record header (expected 0xA3 0x95); the 7 "
                                "bytes from there are ignored"),
            std::string::npos)
      << g.truncation();
  std::string unknown = log;
  unknown[187] = '\x90';
  EXPECT_NE(DataFlashFile::parse(unknown, "x.bin")
                .truncation()
                .find("byte 185: message id 144 has no FMT record before it"),
            std::string::npos);
  // Every cut of the log parses without throwing or reading past the end.
  for (std::size_t cut = 1; cut <= log.size(); ++cut)
    EXPECT_NO_THROW(DataFlashFile::parse(log.substr(0, cut), "x.bin")) << cut;
}

constexpr const char* kNoSharedLog =
    "../shared/data/ardupilot-copter/log171.bin is absent (tests that need the shared real data "
    "skip without it)";

std::string shared_log_bytes() {
  const fs::path p = fs::path(INSID_SHARED_DATA) / "ardupilot-copter" / "log171.bin";
  std::ifstream in(p, std::ios::binary);
  if (!in) return "";
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The expected numbers were read independently of this reader, with a 40-line Python decoder
// (struct.unpack on the FMT-defined layouts, /usr/bin/python3, run once while writing this test):
// 11916 records each of IMU/IMU2/IMU3, 1199 GPS, 1038 of them with Status 3 (none above); the
// first such fix Week 1871 TimeMS 603882400 T 45136, the last TimeMS 604091400 T 254071; cut at
// byte 1500000 the last whole record ends before 1499984 (an IMU record starts there), with 5925
// IMU and 594 GPS records before it; IMU's FMT record is at byte 267 ('IffffffIIf' at 276);
// d(Alt)/dt = -0.978 VZ over central differences of the fixes (correlation -0.93).
TEST(ArduPilotReal, CountsFixesAndVzSign) {
  const std::string bytes = shared_log_bytes();
  if (bytes.empty()) GTEST_SKIP() << kNoSharedLog;
  const DataFlashFile log = DataFlashFile::parse(bytes, "log171.bin");
  EXPECT_EQ(log.truncation(), "");
  for (const char* imu : {"IMU", "IMU2", "IMU3"}) EXPECT_EQ(log.count(imu), 11916u) << imu;
  EXPECT_EQ(log.count("GPS"), 1199u);
  const auto gps = log.read("GPS", {"Status", "Week", "TimeMS", "T"});
  std::size_t status3 = 0;
  for (const auto& r : gps) status3 += r[0] == 3.0;
  EXPECT_EQ(status3, 1038u);

  const ArduPilotSeries s = extract_ardupilot(log, "log171.bin", ArduPilotImportOptions{});
  // 1038 fixes, one of them a second record stamped 603911.0 s (TimeMS repeated, logged in the
  // burst after the logging gap): dropped as not increasing.
  ASSERT_EQ(s.gnss.epochs.size(), 1037u);
  const GpstTime week = kGpsEpochGpstUnix_s + 1871.0L * kSecondsPerWeek;
  EXPECT_NEAR(static_cast<double>(s.gnss.epochs.front().t_gpst_unix_s - week), 603882.4, 1e-6);
  EXPECT_NEAR(static_cast<double>(s.gnss.epochs.back().t_gpst_unix_s - week), 604091.4, 1e-6);
  EXPECT_TRUE(s.vz.conclusive);
  EXPECT_TRUE(s.vz.down_positive);
  EXPECT_NEAR(s.vz.s, -0.978, 0.005);
  EXPECT_NEAR(s.vz.correlation, -0.927, 0.005);
  EXPECT_EQ(s.imu.t_gpst_unix_s.size(), 11916u);
  // The steps beyond 3 median steps (Python: TimeMS 21806 then 21887, 72606 then 74628; the
  // median step is 20 ms).
  ASSERT_EQ(s.imu_gaps_boot_s.size(), 2u);
  EXPECT_NEAR(s.imu_gaps_boot_s[0].first, 21.806, 1e-9);
  EXPECT_NEAR(s.imu_gaps_boot_s[0].second, 0.081, 1e-9);
  EXPECT_NEAR(s.imu_gaps_boot_s[1].first, 72.606, 1e-9);
  EXPECT_NEAR(s.imu_gaps_boot_s[1].second, 2.022, 1e-9);
  EXPECT_FALSE(s.imu.gyro_is_increment);
  EXPECT_FALSE(s.imu.accel_is_increment);
  EXPECT_FALSE(s.imu.rates_are_interval_means);  // point samples, as import csv's default
  // The boot clock: the 3 fixes logged in a burst after the logging gap at 72.6 s are left out.
  EXPECT_EQ(s.clock.excluded, 3u);
  EXPECT_NEAR(s.clock.slope, 1.0, 1e-4);
  EXPECT_LT(s.clock.rms_s, 0.05);
  // The first fix: boot 45.136 s.
  EXPECT_NEAR(static_cast<double>(s.clock.gpst_at_boot_zero_s +
                                  static_cast<long double>(s.clock.slope) * 45.136L - week),
              603882.4, 0.1);
  bool aliasing = false;
  for (const std::string& n : s.notes) aliasing |= n.find("aliases") != std::string::npos;
  EXPECT_TRUE(aliasing);

  ArduPilotImportOptions cut;
  cut.imu = "IMU3";
  cut.t_end_s = 230.0;
  const ArduPilotSeries c = extract_ardupilot(log, "log171.bin", cut);
  EXPECT_LT(c.imu.t_gpst_unix_s.size(), 11916u);
  EXPECT_EQ(c.imu.rows_dropped.at("outside_t_range") + c.imu.t_gpst_unix_s.size(), 11916u);
}

TEST(ArduPilotReal, TruncatedAndCorruptedCopies) {
  const std::string bytes = shared_log_bytes();
  if (bytes.empty()) GTEST_SKIP() << kNoSharedLog;
  const DataFlashFile cut = DataFlashFile::parse(bytes.substr(0, 1500000), "cut.bin");
  EXPECT_NE(cut.truncation().find("cut.bin: byte 1499984: the file ends inside a record of IMU"),
            std::string::npos)
      << cut.truncation();
  EXPECT_EQ(cut.count("IMU"), 5925u);
  EXPECT_EQ(cut.count("GPS"), 594u);
  const ArduPilotSeries s = extract_ardupilot(cut, "cut.bin", ArduPilotImportOptions{});
  EXPECT_EQ(s.imu.t_gpst_unix_s.size(), 5925u);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.front().find("byte 1499984"), std::string::npos);

  // Cut inside, or right after, the FMT records at its start: the error says it looks truncated.
  for (const std::size_t end : {std::size_t{2937}, std::size_t{3000}}) {
    try {
      extract_ardupilot(DataFlashFile::parse(bytes.substr(0, end), "defs.bin"), "defs.bin",
                        ArduPilotImportOptions{});
      ADD_FAILURE() << end;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("no GPS records"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("the file holds no record but its 32 FMT records (" +
                                           std::to_string(end) +
                                           " bytes): it looks truncated after its definitions"),
                std::string::npos)
          << e.what();
    }
  }

  std::string corrupted = bytes;
  ASSERT_EQ(corrupted.compare(276, 10, "IffffffIIf"), 0);
  corrupted[277] = 'X';
  EXPECT_NE(parse_error(corrupted).find("x.bin: byte 267: FMT record for message id 131 (IMU): "
                                        "field Format 'IXfffffIIf': unknown type letter 'X' for "
                                        "field GyrX"),
            std::string::npos)
      << parse_error(corrupted);
}

// One flipped bit in one IMU TimeMS of the shared log: that record is dropped and named, the
// import keeps every other record (no logging gap appears), and the flight's phases stay those of
// the intact log. Bit 14 moves record 6000 (boot 134.775 s) 16.4 s ahead, inside the flight; bit
// 20 moves it to 1183 s, past the log's end.
TEST(ArduPilotReal, AFlippedImuStampCostsItsOwnRecord) {
  const std::string bytes = shared_log_bytes();
  if (bytes.empty()) GTEST_SKIP() << kNoSharedLog;
  const DataFlashFile clean = DataFlashFile::parse(bytes, "log171.bin");
  ArduPilotImportOptions options;
  options.t_start_s = 74.7;
  options.t_end_s = 215.0;
  const ArduPilotSeries intact = extract_ardupilot(clean, "log171.bin", options);
  const std::size_t at = clean.offsets("IMU").at(5999) + 3;  // TimeMS, the first field
  for (const int bit : {14, 20}) {
    std::string damaged = bytes;
    damaged[at + bit / 8] = static_cast<char>(damaged[at + bit / 8] ^ (1 << (bit % 8)));
    const ArduPilotSeries s =
        extract_ardupilot(DataFlashFile::parse(damaged, "x.bin"), "x.bin", options);
    EXPECT_EQ(s.imu.rows_dropped.at("timestamp_jump"), 1u) << bit;
    EXPECT_EQ(s.imu.t_gpst_unix_s.size() + 1, intact.imu.t_gpst_unix_s.size()) << bit;
    EXPECT_EQ(s.imu_gaps_boot_s.size(), intact.imu_gaps_boot_s.size()) << bit;
    EXPECT_EQ(s.phases.to_json().dump(), intact.phases.to_json().dump()) << bit;
    bool named = false;
    for (const std::string& n : s.notes)
      named |=
          n.find("message 6000 (TimeMS at byte " + std::to_string(at) + ")") != std::string::npos &&
          n.find(": dropped") != std::string::npos;
    EXPECT_TRUE(named) << bit;
  }
}

// A NaN gyro in one IMU record of the shared log: the dataset check names the
// log, the IMU, the record and the byte where the record starts (the record's header and its
// TimeMS are checked at that byte here, independently of the reader).
TEST(ArduPilotReal, ANonFiniteGyroIsNamedWithItsRecordAndByte) {
  std::string bytes = shared_log_bytes();
  if (bytes.empty()) GTEST_SKIP() << kNoSharedLog;
  const DataFlashFile clean = DataFlashFile::parse(bytes, "log171.bin");
  const std::size_t record = 6000;  // 1-based, as the error counts; boot ~122 s, airborne
  const std::size_t at = clean.offsets("IMU").at(record - 1);
  // IMU is message id 131 ('IffffffIIf': TimeMS, GyrX, GyrY, ...), after the 3 header bytes.
  ASSERT_EQ(bytes.compare(at, 3, "\xA3\x95\x83"), 0);
  std::uint32_t time_ms = 0;
  std::memcpy(&time_ms, &bytes[at + 3], sizeof time_ms);
  ASSERT_EQ(static_cast<double>(time_ms), clean.read("IMU", {"TimeMS"}).at(record - 1).at(0));
  ASSERT_GT(time_ms, 100000u);
  ASSERT_LT(time_ms, 200000u);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&bytes[at + 3 + 4 + 4], &nan, sizeof nan);  // GyrY
  ArduPilotImportOptions options;
  options.t_start_s = 74.7;
  options.t_end_s = 215.0;
  const ArduPilotSeries s =
      extract_ardupilot(DataFlashFile::parse(bytes, "log171.bin"), "log171.bin", options);
  try {
    assemble_dataset(s.imu, s.gnss, AssembleOptions{});
    ADD_FAILURE() << "a NaN gyro was accepted";
  } catch (const DatasetError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("log171.bin, IMU record " + std::to_string(record) + " (byte " +
                        std::to_string(at) + ") (dtheta_y_rad)"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("expected a finite number"), std::string::npos) << what;
  }
}

TEST(ArduPilotImport, OptionsValidated) {
  ArduPilotImportOptions o;
  EXPECT_EQ(o.validate(), "");
  o.imu = "IMU4";
  EXPECT_NE(o.validate().find("--imu 'IMU4'"), std::string::npos);
  o.imu = "IMU2";
  o.t_start_s = 100.0;
  o.t_end_s = 50.0;
  EXPECT_NE(o.validate().find("must be before --t-end"), std::string::npos);
}

// GIVEN a synthetic 50 Hz multicopter log from boot 10 s to 70 s: still until 30 s (|f| = g,
// scatter 0), the motors on from 30 s (a 0.5 m/s^2 vibration at 17 Hz on f_z), GPS at 5 Hz level
// at 100 m until 35 s and climbing 1 m/s after, an impact of 8 g at 60 s and upside down
// (f_z = +g) from 61 s WHEN its phases are found THEN the motors start at 30 s, the take-off is
// the first fix more than 1 m up (36.2 s), the crash at 60 s ends the flight, upside down from
// 61 s, and the suggested window ends 2 s before the crash. Without the crash, climbing to 5 m
// at 40 s, back on the ground at 45 s and the motors off at 50 s, it ends with a landing at 50 s.
TEST(FlightPhases, SyntheticFlightGivesItsPhases) {
  const auto make = [](bool crash) {
    FlightPhaseInput in;
    for (int k = 0; k <= 60 * 50; ++k) {
      const double t = 10.0 + k * 0.02;
      Eigen::Vector3d f(0.0, 0.0, -9.80665);
      const bool motors = t >= 30.0 && (crash || t < 50.0);
      if (motors) f.z() += 0.5 * std::sin(2.0 * 3.14159265358979323846 * 17.0 * t);
      if (crash && std::fabs(t - 60.0) < 1e-9) f = {0.0, 0.0, -8.0 * 9.80665};
      if (crash && t >= 61.0) f.z() = 9.80665;
      in.imu_boot_s.push_back(t);
      in.f_b_mps2.push_back(f);
      in.omega_b_rad_s.emplace_back(0.0, 0.0, 0.0);
    }
    for (int k = 0; k <= 60 * 5; ++k) {
      const double t = 10.0 + k * 0.2;
      in.gnss_boot_s.push_back(t);
      const double up = crash ? std::max(0.0, t - 35.0) : std::clamp(t - 35.0, 0.0, 45.0 - t);
      in.gnss_alt_m.push_back(100.0 + std::max(0.0, up));
      in.gnss_speed_mps.push_back(0.0);
    }
    return in;
  };
  const FlightPhases p = find_flight_phases(make(true), FlightPhaseOptions{});
  ASSERT_TRUE(p.motors_on_s && p.takeoff_s && p.crash_s && p.inverted_s);
  EXPECT_NEAR(*p.motors_on_s, 30.0, 1e-9);
  EXPECT_NEAR(p.ground_alt_m, 100.0, 1e-9);
  EXPECT_NEAR(*p.takeoff_s, 36.2, 1e-9);  // 1.2 m up: the first fix beyond 1 m
  EXPECT_NEAR(*p.crash_s, 60.0, 1e-9);
  EXPECT_NEAR(*p.inverted_s, 61.0, 1e-9);
  EXPECT_EQ(p.ended_by, "crash");
  EXPECT_NEAR(p.airborne_end_s, 60.0, 1e-9);
  EXPECT_NEAR(p.suggest_t_end_s, 58.0, 1e-9);
  EXPECT_NEAR(p.peak_airborne_g, 1.0 + 0.5 / 9.80665, 1e-3);
  const FlightPhases l = find_flight_phases(make(false), FlightPhaseOptions{});
  ASSERT_TRUE(l.takeoff_s && l.landed_s);
  EXPECT_FALSE(l.crash_s);
  EXPECT_NEAR(*l.landed_s, 50.0, 1e-9);
  EXPECT_EQ(l.ended_by, "landing");
  EXPECT_NEAR(l.suggest_t_end_s, l.log_end_s, 1e-9);
  FlightPhaseOptions bad;
  bad.spin_fraction = 0.0;
  EXPECT_NE(bad.validate().find("spin_fraction"), std::string::npos);
}

// Stamps so large that a 0.5 s block adds nothing to them (a damaged log the fuzzer made): every
// record still opens or joins a block, one block per record at most (this looped, allocating
// blocks until memory ran out).
TEST(FlightPhases, StampsBeyondTheBlockResolutionStillEnd) {
  FlightPhaseInput in;
  for (int k = 0; k < 50; ++k) {
    in.imu_boot_s.push_back(1e17 + 16.0 * k);  // the ulp at 1e17 is 16 s
    in.f_b_mps2.emplace_back(0.0, 0.0, -9.80665);
    in.omega_b_rad_s.emplace_back(0.0, 0.0, 0.0);
  }
  const FlightPhases p = find_flight_phases(in, FlightPhaseOptions{});
  EXPECT_EQ(p.log_start_s, 1e17);
  EXPECT_FALSE(p.motors_on_s);
}

// The EKF bias fields of a crafted log (ArduPilot 3.x layouts "IccCffffffccc" and
// "Ibbbcchhhhhh", LogStructure.h) with distinct values per axis: GX = -150, GY = 250, GZ = -5
// centi-deg/s and AZ1bias = -7, AZ2bias = 12 cm/s^2 give -1.5, 2.5, -0.05 deg/s and -0.07,
// 0.12 m/s^2 on gyro_bias_x/y/z and accel_bias_z of IMU and IMU2. A GX written with another
// letter is left out with a note, never read with a guessed scale.
TEST(ArduPilotImport, AutopilotBiasesFromCraftedEkfRecords) {
  const auto crafted = [](const std::string& ekf1_letters) {
    std::string log = fmt_of_fmt();
    log += fmt_record(140, 43, "EKF1", ekf1_letters,
                      "TimeMS,Roll,Pitch,Yaw,VN,VE,VD,PN,PE,PD,GX,GY,GZ");
    log += fmt_record(141, 26, "EKF2", "Ibbbcchhhhhh",
                      "TimeMS,Ratio,AZ1bias,AZ2bias,VWN,VWE,MN,ME,MD,MX,MY,MZ");
    for (std::uint32_t t_ms : {1000u, 2000u}) {
      std::string r = "\xA3\x95\x8C";
      put<std::uint32_t>(r, t_ms);
      put<std::int16_t>(r, 0), put<std::int16_t>(r, 0), put<std::uint16_t>(r, 0);
      for (int i = 0; i < 6; ++i) put<float>(r, 0.0f);
      put<std::int16_t>(r, t_ms == 2000u ? -150 : 0);
      put<std::int16_t>(r, t_ms == 2000u ? 250 : 0);
      put<std::int16_t>(r, t_ms == 2000u ? -5 : 0);
      log += r;
      std::string r2 = "\xA3\x95\x8D";
      put<std::uint32_t>(r2, t_ms);
      put<std::int8_t>(r2, 50), put<std::int8_t>(r2, t_ms == 2000u ? -7 : 0);
      put<std::int8_t>(r2, t_ms == 2000u ? 12 : 0);
      for (int i = 0; i < 8; ++i) put<std::int16_t>(r2, 0);
      log += r2;
    }
    return DataFlashFile::parse(log, "ekf.bin");
  };
  std::vector<std::string> notes;
  ArduPilotImportOptions options;
  const nlohmann::json ap =
      autopilot_bias_estimates(crafted("IccCffffffccc"), FlightPhases{}, options, notes);
  ASSERT_EQ(ap.at("estimates").size(), 5u);
  constexpr double kDegS = 3.14159265358979323846 / 180.0;
  const double want[] = {-1.5 * kDegS, 2.5 * kDegS, -0.05 * kDegS, -0.07, 0.12};
  const char* effects[] = {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "accel_bias_z",
                           "accel_bias_z"};
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(ap["estimates"][k]["effect"], effects[k]) << k;
    EXPECT_NEAR(ap["estimates"][k]["end_si"].get<double>(), want[k], 1e-12) << k;
    EXPECT_NEAR(ap["estimates"][k]["end_boot_s"].get<double>(), 2.0, 1e-12) << k;
  }
  EXPECT_EQ(ap["estimates"][4]["imu"], "IMU2");
  EXPECT_TRUE(ap["estimates"][4]["airborne_mean_si"].is_null());  // no flight found

  notes.clear();
  const nlohmann::json other =
      autopilot_bias_estimates(crafted("IccCffffffhcc"), FlightPhases{}, options, notes);
  ASSERT_EQ(other.at("estimates").size(), 4u);
  EXPECT_EQ(other["estimates"][0]["source"], "EKF1.GY");
  bool named = false;
  for (const std::string& n : notes)
    named |= n.find("EKF1.GX left out: its FMT letter is 'h'") != std::string::npos;
  EXPECT_TRUE(named);
}

// A physical check of which IMU each EKF2 accelerometer bias belongs to and of its scale: on the
// ground before the motors start (boot 75-82 s) the |specific force| of IMU and IMU2 falls short
// of the normal gravity there (WGS-84 at the first fix, ~9.795 m/s^2) by 0.206 and 0.383 m/s^2
// (a body z down with a positive z bias reads |f| short by the bias: FRD f_z = -g + b_z). The
// EKF's estimates wander on the ground (at 82 s: 0.27, 0.50) and settle in flight: their
// airborne means (74.7-215 s cut) are 0.221 and 0.435 m/s^2, within 0.06 of their own IMU's
// deficit and more than 0.1 from the other's. Swapped IMUs, or a scale off by 10, fail.
TEST(ArduPilotReal, EkfAccelZBiasesMatchEachImusGroundDeficit) {
  const std::string bytes = shared_log_bytes();
  if (bytes.empty()) GTEST_SKIP() << kNoSharedLog;
  const DataFlashFile log = DataFlashFile::parse(bytes, "log171.bin");
  ArduPilotImportOptions options;
  options.t_start_s = 74.7;
  options.t_end_s = 215.0;
  const ArduPilotSeries s = extract_ardupilot(log, "log171.bin", options);
  const double g =
      EarthModel::wgs84().normal_gravity_mps2(-35.362 * 3.14159265358979323846 / 180.0, 590.7);
  const auto deficit = [&](const char* imu) {
    double sum = 0.0;
    int n = 0;
    for (const auto& r : log.read(imu, {"TimeMS", "AccX", "AccY", "AccZ"}))
      if (r[0] >= 75000.0 && r[0] <= 82000.0)
        sum += std::sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3]), ++n;
    return g - sum / n;
  };
  double az1 = 0.0, az2 = 0.0;
  for (const nlohmann::json& e : s.autopilot_estimates.at("estimates")) {
    if (e["source"] == "EKF2.AZ1bias") az1 = e["airborne_mean_si"];
    if (e["source"] == "EKF2.AZ2bias") az2 = e["airborne_mean_si"];
  }
  EXPECT_NEAR(az1, deficit("IMU"), 0.06);
  EXPECT_NEAR(az2, deficit("IMU2"), 0.06);
  EXPECT_GT(std::fabs(az1 - deficit("IMU2")), 0.1);
  EXPECT_GT(std::fabs(az2 - deficit("IMU")), 0.1);
}

}  // namespace
}  // namespace insid::importers
