// The binary never loses a user's file: an import into the folder
// of its own raw log, outputs over the command's inputs or over files insid did not write, links
// planted in a campaign directory, and --force-new over a user's file in runs/. Each case ends
// non-zero with the file named, and the user's file is unchanged.
#include <sys/xattr.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "test_support/files.h"
#include "test_support/process.h"

namespace {
namespace fs = std::filesystem;

namespace test = insid::test;
using insid::test::insid;
using insid::test::Outcome;

class CliOwnership : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = test::fresh_dir("cli-ownership");
    fs::create_directories(root_);
    std::ofstream(root_ / "probe") << "x";
    marks_ = ::setxattr((root_ / "probe").c_str(), "user.insid.probe", "1", 1, 0) == 0;
    data_ = root_ / "data";
    const Outcome o = insid("simulate --preset straight --flight-s 20 --out " + data_.string());
    ASSERT_EQ(o.status, 0) << o.output;
    kf_ = root_ / "kf";
    const Outcome e =
        insid("export --to kf-gins --data " + data_.string() + " --out " + kf_.string());
    ASSERT_EQ(e.status, 0) << e.output;
  }
  void TearDown() override { fs::remove_all(root_); }

  std::string import_kf(const fs::path& imu, const fs::path& out) const {
    return "import kf-gins --imu " + imu.string() + " --gnss " + (kf_ / "gnss.txt").string() +
           " --align-s 600 --static-rate 5 --static-accel-sd 0.3 --out " + out.string();
  }

  fs::path root_, data_, kf_;
  bool marks_ = false;
};

// Item 1: a folder of files with dataset names is not a dataset; the raw log stays.
TEST_F(CliOwnership, AnImportNeverReplacesItsOwnRawLog) {
  const fs::path walk = root_ / "walk";
  fs::create_directories(walk);
  fs::copy_file(kf_ / "imu.txt", walk / "imu.csv");  // the user's raw log, named like insid's
  const std::string raw = test::read_file(walk / "imu.csv");
  Outcome o = insid(import_kf(walk / "imu.csv", walk));
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "it holds 'imu.csv'")) << o.output;
  EXPECT_EQ(test::read_file(walk / "imu.csv"), raw);
  // --force adds the dataset's files to a foreign folder, but never over the command's input.
  o = insid(import_kf(walk / "imu.csv", walk) + " --force");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "which this command reads")) << o.output;
  EXPECT_EQ(test::read_file(walk / "imu.csv"), raw);
  EXPECT_FALSE(fs::exists(walk / "meta.json"));
  // simulate over a folder holding only look-alike names: refused too.
  const fs::path look = root_ / "look";
  fs::create_directories(look);
  std::ofstream(look / "meta.json") << "{\"format\": \"insid-dataset/1\"}";
  std::ofstream(look / "gnss.csv") << "the user's";
  o = insid("simulate --preset straight --flight-s 5 --out " + look.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_EQ(test::read_file(look / "gnss.csv"), "the user's");
  // An insid dataset is still replaced as a whole (its files carry insid's mark).
  if (!marks_) GTEST_SKIP() << "no user extended attributes here: insid cannot mark its files";
  o = insid("simulate --preset straight --flight-s 10 --out " + data_.string());
  EXPECT_EQ(o.status, 0) << o.output;
  // ... and an import may write into the folder of a raw log it does not touch.
  const fs::path mixed = root_ / "mixed";
  o = insid(import_kf(kf_ / "imu.txt", mixed));
  EXPECT_EQ(o.status, 0) << o.output;
  o = insid(import_kf(kf_ / "imu.txt", mixed));  // again: its own dataset, replaced
  EXPECT_EQ(o.status, 0) << o.output;
}

// Item 5: outputs over the command's inputs, or over a file insid did not write.
TEST_F(CliOwnership, OutputsNeverReplaceInputsOrOtherFiles) {
  const std::string imu = test::read_file(data_ / "imu.csv"),
                    meta = test::read_file(data_ / "meta.json");
  for (const std::string& args :
       {"navigate --data " + data_.string() + " --out " + (data_ / "imu.csv").string(),
        "navigate --data " + data_.string() + " --summary " + (data_ / "meta.json").string(),
        "navigate --force --data " + data_.string() + " --summary " + (data_ / "gnss.csv").string(),
        "identify --algo pso --iterations 2 --data " + data_.string() + " --out " +
            (data_ / "meta.json").string(),
        "diagnose --data " + data_.string() + " --out " + (data_ / "truth.csv").string()}) {
    const Outcome o = insid(args);
    EXPECT_EQ(o.status, 1) << args << "\n" << o.output;
    EXPECT_TRUE(test::contains(o.output, "which this command reads")) << args << "\n" << o.output;
  }
  EXPECT_EQ(test::read_file(data_ / "imu.csv"), imu);
  EXPECT_EQ(test::read_file(data_ / "meta.json"), meta);
  EXPECT_EQ(insid("navigate --data " + data_.string()).status, 0);  // the dataset still loads

  // A file of the user's as an output: refused before the work, replaced with --force.
  const fs::path notes = root_ / "notes.json";
  std::ofstream(notes) << "mine";
  Outcome o = insid("navigate --data " + data_.string() + " --summary " + notes.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "insid did not write it")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--force")) << o.output;
  EXPECT_EQ(test::read_file(notes), "mine");
  o = insid("identify --algo pso --iterations 2 --data " + data_.string() + " --out " +
            notes.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_EQ(test::read_file(notes), "mine");
  o = insid("navigate --force --data " + data_.string() + " --summary " + notes.string());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(test::read_file(notes), "mine");
  // insid's own output is replaced by the next run without --force.
  if (!marks_) GTEST_SKIP() << "no user extended attributes here: insid cannot mark its files";
  const fs::path nav = root_ / "nav.csv";
  for (int k = 0; k < 2; ++k) {
    o = insid("navigate --data " + data_.string() + " --out " + nav.string());
    EXPECT_EQ(o.status, 0) << o.output;
  }
}

// Items 2 and 6: links planted in a campaign directory, a user's summary.json, a user's file
// under runs/ when --force-new discards the results of another campaign.
TEST_F(CliOwnership, CampaignDirectoriesFollowNoLinkAndDeleteOnlyInsidsFiles) {
  if (!marks_) GTEST_SKIP() << "no user extended attributes here: insid cannot mark its files";
  const std::string bench = "bench --preset quick --seeds 1 --flight-s 20 --threads 2 --quiet ";
  const fs::path outside = root_ / "outside";
  fs::create_directories(outside);
  std::ofstream(outside / "victim") << "keep";

  // A directory holding only the user's summary.json is not a campaign directory.
  const fs::path user = root_ / "user";
  fs::create_directories(user);
  std::ofstream(user / "summary.json") << "{\"mine\": true}";
  Outcome o = insid(bench + "--out " + user.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "it holds 'summary.json'")) << o.output;
  EXPECT_EQ(test::read_file(user / "summary.json"), "{\"mine\": true}");

  const fs::path c = root_ / "campaign";
  o = insid(bench + "--out " + c.string());
  ASSERT_EQ(o.status, 0) << o.output;
  fs::path run_file;
  for (const auto& e : fs::recursive_directory_iterator(c / "runs"))
    if (e.is_regular_file()) run_file = e.path();
  ASSERT_FALSE(run_file.empty());

  // .insid-lock as a link to a file outside: refused, the file untouched.
  fs::remove(c / ".insid-lock");
  fs::create_symlink(outside / "victim", c / ".insid-lock");
  o = insid(bench + "--out " + c.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "symbolic link")) << o.output;
  EXPECT_EQ(test::read_file(outside / "victim"), "keep");
  fs::remove(c / ".insid-lock");

  // runs/ and optimum/ as links to a directory outside: nothing is written there.
  for (const char* sub : {"runs", "optimum"}) {
    fs::remove_all(c / "runs");  // a run to do, so that the campaign writes both
    fs::remove_all(c / sub);
    fs::create_directory_symlink(outside, c / sub);
    o = insid(bench + "--out " + c.string());
    EXPECT_EQ(o.status, 1) << sub << "\n" << o.output;
    EXPECT_TRUE(test::contains(o.output, "symbolic link")) << sub << "\n" << o.output;
    EXPECT_EQ(std::distance(fs::directory_iterator(outside), fs::directory_iterator()), 1) << sub;
    fs::remove(c / sub);
    o = insid(bench + "--out " + c.string());  // the links gone, the campaign completes again
    ASSERT_EQ(o.status, 0) << o.output;
  }

  // --force-new over a different campaign: insid's runs go, the user's notes stay and are named.
  std::ofstream(c / "runs" / "notes.txt") << "mine";
  o = insid("bench --preset quick --seeds 2 --flight-s 20 --threads 2 --quiet --force-new --out " +
            c.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "runs/notes.txt")) << o.output;
  EXPECT_EQ(test::read_file(c / "runs" / "notes.txt"), "mine");
  EXPECT_TRUE(fs::exists(c / "manifest.json"));
  EXPECT_FALSE(fs::exists(run_file));
}

// A name that merely looks like one of insid's temporaries is the user's. bench --force
// into a folder of photos keeps "photos.tmp-laptop-12-3/img1.jpg" and "list.tmp-h-1-2"; a dataset
// holding a user's folder named like a dataset file is not replaced.
TEST_F(CliOwnership, LookAlikeTemporariesAndFoldersAreTheUsers) {
  if (!marks_) GTEST_SKIP() << "no user extended attributes here: insid cannot mark its files";
  const fs::path photos = root_ / "photos";
  fs::create_directories(photos / "photos.tmp-laptop-12-3");
  std::ofstream(photos / "photos.tmp-laptop-12-3" / "img1.jpg") << "jpeg";
  std::ofstream(photos / "list.tmp-h-1-2") << "mine";
  const std::string bench = "bench --preset quick --seeds 1 --flight-s 20 --threads 2 --quiet ";
  Outcome o = insid(bench + "--force --out " + photos.string());
  ASSERT_EQ(o.status, 0) << o.output;
  o = insid(bench + "--force --out " + photos.string());  // a rerun removes stale temporaries
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(test::read_file(photos / "photos.tmp-laptop-12-3" / "img1.jpg"), "jpeg");
  EXPECT_EQ(test::read_file(photos / "list.tmp-h-1-2"), "mine");

  // ds/provenance.json/notes.txt: a folder where a dataset writes a file.
  const fs::path ds = root_ / "ds";
  ASSERT_EQ(insid("simulate --preset straight --flight-s 5 --out " + ds.string()).status, 0);
  fs::create_directories(ds / "provenance.json");
  std::ofstream(ds / "provenance.json" / "notes.txt") << "mine";
  o = insid("simulate --preset straight --flight-s 5 --out " + ds.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "it holds 'provenance.json'")) << o.output;
  EXPECT_EQ(test::read_file(ds / "provenance.json" / "notes.txt"), "mine");
  o = insid("import kf-gins --imu " + (kf_ / "imu.txt").string() + " --gnss " +
            (kf_ / "gnss.txt").string() +
            " --align-s 600 --static-rate 5 --static-accel-sd 0.3 --force --out " + ds.string());
  EXPECT_EQ(o.status, 1) << o.output;  // provenance.json cannot be written over a folder
  EXPECT_EQ(test::read_file(ds / "provenance.json" / "notes.txt"), "mine");
}

// --force never overwrites a file the same command reads: simulate's config, bench's
// campaign config, at any path the command would write.
TEST_F(CliOwnership, ForceNeverOverwritesTheCommandsOwnInput) {
  const fs::path cfg = root_ / "cfg";
  fs::create_directories(cfg);
  Outcome o = insid("simulate --preset straight --flight-s 5 --print-config");
  ASSERT_EQ(o.status, 0) << o.output;
  const std::string scenario = o.output.substr(o.output.find('{'));
  std::ofstream(cfg / "meta.json") << scenario;
  o = insid("simulate --config " + (cfg / "meta.json").string() + " --force --out " + cfg.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "which this command reads")) << o.output;
  EXPECT_EQ(test::read_file(cfg / "meta.json"), scenario);

  const fs::path bc = root_ / "bc";
  fs::create_directories(bc / "runs");
  const std::string campaign =
      R"({"scenarios": [{"name": "s", "preset": "rich", "flight_s": 20}],)"
      R"( "algorithms": [{"label": "P", "name": "pso"}], "max_iterations": 2, "seeds": [1]})";
  for (const fs::path& config : {bc / "summary.json", bc / "runs" / "c.json"}) {
    std::ofstream(config) << campaign;
    o = insid("bench --config " + config.string() + " --force --quiet --out " + bc.string());
    EXPECT_EQ(o.status, 1) << config << "\n" << o.output;
    EXPECT_TRUE(test::contains(o.output, "which this command reads")) << config << "\n" << o.output;
    EXPECT_EQ(test::read_file(config), campaign) << config;
    EXPECT_FALSE(fs::exists(bc / "manifest.json")) << config;  // refused before any work
  }
}

// Two outputs of one command at the same path are a usage error (exit 2), not a
// silent replacement of the first by the second.
TEST_F(CliOwnership, TwoOutputsOfOneCommandAtOnePathAreRefused) {
  const fs::path x = root_ / "x.json";
  Outcome o = insid("diagnose --data " + data_.string() + " --out " + x.string() + " --report " +
                    x.string());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "are the same file")) << o.output;
  EXPECT_FALSE(fs::exists(x));
  o = insid("diagnose --data " + data_.string() + " --report " + x.string());
  EXPECT_EQ(o.status, 2) << o.output;  // the report's JSON would be x.json too
  o = insid("navigate --data " + data_.string() + " --out " + x.string() + " --summary " +
            (root_ / "." / "x.json").string());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_FALSE(fs::exists(x));
}

}  // namespace
