// The insid binary as a careless user meets it: a user directory as --out, a corrupted value in
// imu.csv, a compensation that blows the navigation up, an alignment window of zero. Each must
// end non-zero with the file, line or option named, and leave nothing half-written.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace {
namespace fs = std::filesystem;

struct Outcome {
  int status = -1;
  std::string output;  // stdout and stderr
};

Outcome insid(const std::string& args) {
  Outcome o;
  FILE* pipe = ::popen((std::string(INSID_BINARY) + " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return o;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) o.output += buffer.data();
  const int raw = ::pclose(pipe);
  o.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return o;
}

std::string text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CliSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("insid-cli-safety-" + std::to_string(getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    data_ = root_ / "data";
    const Outcome o = insid("simulate --preset straight --flight-s 20 --out " + data_.string());
    ASSERT_EQ(o.status, 0) << o.output;
  }
  void TearDown() override { fs::remove_all(root_); }

  // Replace line `line` (1-based) of `file` by `value`.
  static void set_line(const fs::path& file, int line, const std::string& value) {
    std::istringstream in(text(file));
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
  EXPECT_EQ(text(proj / "src" / "code.c"), "int main;");
  EXPECT_FALSE(fs::exists(proj / "imu.csv"));
  const Outcome forced = insid("simulate --preset straight --flight-s 5 --force --out " + proj.string());
  EXPECT_EQ(forced.status, 0) << forced.output;
  EXPECT_EQ(text(proj / "src" / "code.c"), "int main;");
  EXPECT_TRUE(fs::exists(proj / "imu.csv"));
}

TEST_F(CliSafety, OneHugeImuValueIsAnErrorNamingFileAndLine) {
  const std::string clean = text(data_ / "imu.csv");
  for (const std::string value : {"1e300", "-9.8e15"}) {
    set_line(data_ / "imu.csv", 123, "1.22," + value + ",0,0,0,0,-0.0979");
    const fs::path summary = root_ / "s.json";
    const Outcome o = insid("navigate --data " + data_.string() + " --summary " + summary.string());
    EXPECT_NE(o.status, 0) << value;
    EXPECT_NE(o.output.find("imu.csv line 123, column dtheta_x_rad"), std::string::npos) << o.output;
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
  const Outcome o = insid("navigate --data " + data_.string() +
                          " --compensate accel_bias_x=1e30 --summary " + summary.string() +
                          " --out " + nav.string());
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("accel_bias_x=1e+30 became non-finite"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("imu.csv line"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(summary));
  EXPECT_FALSE(fs::exists(nav));
  const Outcome align = insid("navigate --data " + data_.string() + " --compensate accel_bias_x=1e300");
  EXPECT_NE(align.status, 0);
  EXPECT_NE(align.output.find("alignment on imu.csv lines 2-"), std::string::npos) << align.output;
  EXPECT_NE(align.output.find("accel_bias_x=1e+300"), std::string::npos) << align.output;
}

TEST_F(CliSafety, ZeroAlignmentWindowWorksWithTruthAndIsNamedWithoutIt) {
  std::string meta = text(data_ / "meta.json");
  const auto at = meta.find("\"align_s\"");
  const auto colon = meta.find(':', at);
  const auto end = meta.find_first_of(",}", colon);
  std::ofstream(data_ / "meta.json", std::ios::trunc) << meta.substr(0, colon + 1) + " 0.004" + meta.substr(end);
  const Outcome without = insid("navigate --data " + data_.string());
  EXPECT_NE(without.status, 0);
  EXPECT_NE(without.output.find("align_s = 0.004 s"), std::string::npos) << without.output;
  const fs::path summary = root_ / "s.json";
  const Outcome truth = insid("navigate --data " + data_.string() +
                              " --initial-attitude truth --summary " + summary.string());
  EXPECT_EQ(truth.status, 0) << truth.output;
  EXPECT_NE(text(summary).find("\"fitness\": "), std::string::npos);
  EXPECT_EQ(text(summary).find("null"), std::string::npos) << text(summary);
}

}  // namespace
