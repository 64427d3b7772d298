// `insid import ardupilot` end to end through the insid binary on the shared ArduPilot log
// (../shared/data/ardupilot-copter/log171.bin, read in place; copies cut or corrupted only in a
// temporary directory), then `insid navigate` on the dataset. Skips where the log is absent.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/cli_test_support.h"

namespace {
namespace fs = std::filesystem;

using insid::cli_test::insid;
using insid::cli_test::Outcome;

const fs::path kLog = fs::path(INSID_SHARED_DATA) / "ardupilot-copter" / "log171.bin";
constexpr const char* kNoLog =
    "../shared/data/ardupilot-copter/log171.bin is absent (tests that need the shared real data "
    "skip without it)";

struct TempDir {
  fs::path path;
  TempDir() {
    std::string t = (fs::temp_directory_path() / "insid-ardupilot-XXXXXX").string();
    path = ::mkdtemp(t.data()) ? fs::path(t) : fs::path();
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string file_bytes(const fs::path& p) { return insid::cli_test::text(p); }

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

// Options are checked before any file is read (exit 2, the README's table); no shared data needed.
TEST(ArduPilotCli, UsageErrorsBeforeReading) {
  TempDir tmp;
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
  TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const fs::path refused = tmp.path / "refused";
  Outcome o = insid("import ardupilot " + kLog.string() + " --out " + refused.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("logging gap of 2.022 s after boot time 72.606 s"), std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--t-start 74.628"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(refused));

  const fs::path ds = tmp.path / "ds";
  o = insid("import ardupilot " + kLog.string() + " --t-start 74.7 --t-end 215 --out " +
            ds.string());
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
  o = insid("navigate --data " + ds.string() + " --initial-attitude level+heading --summary " + (tmp.path / "nav.json").string());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(fs::exists(tmp.path / "nav.json"));
}

// A copy cut at byte 1500000 imports what came before and names the offset; a copy whose IMU
// FMT record has an unknown type letter is refused naming the offset, and nothing is written.
TEST(ArduPilotCli, TruncatedAndCorruptedCopies) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const std::string bytes = file_bytes(kLog);
  ASSERT_GT(bytes.size(), 1500000u);
  write_bytes(tmp.path / "cut.bin", bytes.substr(0, 1500000));
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
  write_bytes(tmp.path / "bad.bin", corrupted);
  o = insid("import ardupilot " + (tmp.path / "bad.bin").string() + " --out " +
            (tmp.path / "bad").string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("bad.bin: byte 267: FMT record for message id 131 (IMU)"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "bad"));
}

}  // namespace
