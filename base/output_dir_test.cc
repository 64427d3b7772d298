// What insid may replace or delete (base/output_dir.h): only files carrying its own mark, never a
// command's inputs, never through a symbolic link below an output directory, and no name that
// could pass for one of its temporaries.
#include "base/output_dir.h"
#include "test_support/errors.h"
#include "test_support/files.h"

#include <sys/wait.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace insid {
namespace {

namespace fs = std::filesystem;

class OutputDir : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = test::fresh_dir("output-dir");
    fs::create_directories(root_);
    outside_ = root_ / "outside";
    fs::create_directories(outside_);
    // The tests need user extended attributes (ext4, xfs, btrfs, tmpfs >= 6.6 have them).
    std::ofstream(root_ / "probe") << "x";
    supported_ = ::setxattr((root_ / "probe").c_str(), "user.insid.probe", "1", 1, 0) == 0;
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_, outside_;
  bool supported_ = false;
};

TEST_F(OutputDir, AFileIsInsidsOnlyWhileItMatchesItsMark) {
  if (!supported_) GTEST_SKIP() << root_ << ": no user extended attributes on this file system";
  const fs::path f = root_ / "summary.json";
  EXPECT_EQ(file_owner(f), FileOwner::kAbsent);
  std::ofstream(f) << "{}\n";  // the user's
  EXPECT_EQ(file_owner(f), FileOwner::kOther);
  EXPECT_NE(
      test::error_of([&] { write_file_atomic(f, "{\"a\": 1}\n"); }).find("insid did not write it"),
      std::string::npos);
  EXPECT_EQ(test::read_file(f), "{}\n");
  WriteOptions force;
  force.replace_foreign = true;
  write_file_atomic(f, "{\"a\": 1}\n", force);
  EXPECT_EQ(file_owner(f), FileOwner::kInsid);
  write_file_atomic(f, "{\"a\": 2}\n");  // insid's own: replaced without --force
  EXPECT_EQ(test::read_file(f), "{\"a\": 2}\n");
  std::ofstream(f, std::ios::app) << " ";  // edited by the user: no longer insid's
  EXPECT_EQ(file_owner(f), FileOwner::kOther);
  fs::copy_file(f, root_ / "copy.json");  // a copy does not carry the mark
  EXPECT_EQ(file_owner(root_ / "copy.json"), FileOwner::kOther);
}

TEST_F(OutputDir, ALinkIsNeverWrittenThroughOrReplaced) {
  const fs::path target = outside_ / "precious.txt";
  std::ofstream(target) << "keep";
  fs::create_symlink(target, root_ / "out.json");
  WriteOptions force;
  force.replace_foreign = true;
  EXPECT_NE(test::error_of([&] {
              write_file_atomic(root_ / "out.json", "x", force);
            }).find("symbolic link"),
            std::string::npos);
  EXPECT_EQ(test::read_file(target), "keep");
  EXPECT_TRUE(fs::is_symlink(root_ / "out.json"));
  // A link to a directory inside an output directory: refused, nothing written outside.
  const fs::path campaign = root_ / "campaign";
  fs::create_directories(campaign);
  fs::create_directory_symlink(outside_, campaign / "runs");
  WriteOptions create;
  create.create_directories = true;
  const std::string e = test::error_of(
      [&] { write_file_atomic_under(campaign, "runs/s/a/seed-1.json", "{}", create); });
  EXPECT_NE(e.find("is a symbolic link or not a directory"), std::string::npos) << e;
  EXPECT_EQ(std::distance(fs::directory_iterator(outside_), fs::directory_iterator()), 1);
  // ... and a real one works, creating what is missing.
  fs::remove(campaign / "runs");
  write_file_atomic_under(campaign, "runs/s/a/seed-1.json", "{}", create);
  EXPECT_EQ(test::read_file(campaign / "runs/s/a/seed-1.json"), "{}");
  EXPECT_NE(test::error_of([&] {
              write_file_atomic_under(campaign, "../escape.json", "{}", create);
            }).find("'..'"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(root_ / "escape.json"));
}

TEST_F(OutputDir, TheLockFileIsNotALink) {
  const fs::path target = outside_ / "passwd";
  std::ofstream(target) << "root:x:0:0";
  fs::create_symlink(target, root_ / ".insid-lock");
  EXPECT_NE(test::error_of([&] { FileLock lock(root_ / ".insid-lock"); }).find("symbolic link"),
            std::string::npos);
  EXPECT_EQ(test::read_file(target), "root:x:0:0");
  fs::remove(root_ / ".insid-lock");
  FileLock lock(root_ / ".insid-lock");
  lock.write_text("pid 1 on here\n");
  EXPECT_EQ(lock.read_text(), "pid 1 on here\n");
}

TEST_F(OutputDir, AnOutputNeverReplacesAnInputOfTheSameCommand) {
  const fs::path data = root_ / "walk";
  fs::create_directories(data);
  std::ofstream(data / "imu.csv") << "raw log";
  fs::create_hard_link(data / "imu.csv", root_ / "hard.csv");
  fs::create_symlink(data / "imu.csv", root_ / "soft.csv");
  const std::vector<fs::path> inputs = {data / "imu.csv"};
  for (const fs::path& out : {data / "imu.csv", root_ / "hard.csv", root_ / "soft.csv",
                              data / "." / ".." / "walk" / "imu.csv"})
    EXPECT_NE(test::error_of([&] { refuse_replacing_inputs(out, inputs, false); }).find("reads"),
              std::string::npos)
        << out;
  EXPECT_NE(test::error_of([&] { refuse_replacing_inputs(data, inputs, true); }).find("reads"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { refuse_replacing_inputs(root_, inputs, true); }).find("reads"),
            std::string::npos);
  EXPECT_EQ(test::error_of([&] { refuse_replacing_inputs(data / "gnss.csv", inputs, false); }), "");
  EXPECT_EQ(test::error_of([&] { refuse_replacing_inputs(root_ / "walk2", inputs, true); }), "");
  EXPECT_EQ(test::error_of([&] { refuse_replacing_inputs(data / "sub", inputs, true); }), "");
}

TEST_F(OutputDir, LookAlikeNamesDoNotMakeADirectoryInsids) {
  const OutputKind dataset{"an insid dataset", {"meta.json", "imu.csv", "gnss.csv"}};
  const fs::path dir = root_ / "walk";
  fs::create_directories(dir);
  std::ofstream(dir / "imu.csv") << "the user's raw log";
  const std::string e = test::error_of([&] { require_own_or_empty(dir, dataset, "give --force"); });
  EXPECT_NE(e.find("it holds 'imu.csv'"), std::string::npos) << e;
  if (!supported_) return;
  fs::remove(dir / "imu.csv");
  write_file_atomic(dir / "imu.csv", "insid's");
  EXPECT_EQ(test::error_of([&] { require_own_or_empty(dir, dataset, "give --force"); }), "");
}

TEST_F(OutputDir, RemovingOwnFilesKeepsEverythingElse) {
  if (!supported_) GTEST_SKIP() << root_ << ": no user extended attributes on this file system";
  const fs::path runs = root_ / "runs";
  WriteOptions create;
  create.create_directories = true;
  write_file_atomic_under(root_, "runs/s/a/seed-1.json", "{}", create);
  write_file_atomic_under(root_, "runs/s/b/seed-1.json", "{}", create);
  std::ofstream(runs / "s" / "notes.txt") << "mine";
  fs::create_symlink(outside_, runs / "s" / "link");
  std::ofstream(outside_ / "victim.json") << "keep";
  std::vector<fs::path> kept = remove_own_files(runs);
  std::sort(kept.begin(), kept.end());
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0], fs::path("s/link"));
  EXPECT_EQ(kept[1], fs::path("s/notes.txt"));
  EXPECT_FALSE(fs::exists(runs / "s" / "a"));
  EXPECT_EQ(test::read_file(runs / "s" / "notes.txt"), "mine");
  EXPECT_EQ(test::read_file(outside_ / "victim.json"), "keep");
  // A link in place of the directory: nothing below it is touched.
  fs::remove_all(runs);
  fs::create_directory_symlink(outside_, runs);
  EXPECT_EQ(remove_own_files(runs).size(), 1u);
  EXPECT_EQ(test::read_file(outside_ / "victim.json"), "keep");
}

// A temporary is insid's by its mark, never by its name alone.
TEST_F(OutputDir, ATemporaryIsRecognisedByItsMarkNotItsName) {
  if (!supported_) GTEST_SKIP() << root_ << ": no user extended attributes on this file system";
  const fs::path out = root_ / "out";
  fs::create_directories(out / "photos.tmp-laptop-12-3");
  std::ofstream(out / "photos.tmp-laptop-12-3" / "img1.jpg") << "jpeg";
  std::ofstream(out / "list.tmp-h-1-2") << "mine";
  fs::create_directories(out / "old.old-h-4-5");
  std::ofstream(out / "old.old-h-4-5" / "a.txt") << "mine";
  // What a killed insid leaves: a marked temporary file, and a dataset's marked temporary
  // directory holding one of insid's files (and, put there since, one of the user's).
  const fs::path killed_file = temporary_sibling(out / "summary.json", ".tmp-");
  std::ofstream(killed_file) << "half a fi";
  ASSERT_TRUE(mark_as_temporary(killed_file));
  const fs::path killed_dir = temporary_sibling(out / "ds", ".tmp-");
  fs::create_directories(killed_dir);
  ASSERT_TRUE(mark_as_temporary(killed_dir));
  write_file_atomic(killed_dir / "imu.csv", "t\n");
  EXPECT_TRUE(is_insid_temporary(killed_file));
  EXPECT_TRUE(is_insid_temporary(killed_dir));
  EXPECT_FALSE(is_insid_temporary(out / "photos.tmp-laptop-12-3"));
  EXPECT_FALSE(is_insid_temporary(out / "list.tmp-h-1-2"));
  // A finished write whose rename did not happen: unmarked as a temporary, but insid's file.
  const fs::path finished = temporary_sibling(out / "manifest.json", ".tmp-");
  write_file_atomic(finished, "{}");
  EXPECT_TRUE(is_insid_temporary(finished));

  EXPECT_EQ(remove_stale_temporaries(out), 3);
  EXPECT_FALSE(fs::exists(killed_file));
  EXPECT_FALSE(fs::exists(killed_dir));
  EXPECT_FALSE(fs::exists(finished));
  EXPECT_EQ(test::read_file(out / "photos.tmp-laptop-12-3" / "img1.jpg"), "jpeg");
  EXPECT_EQ(test::read_file(out / "list.tmp-h-1-2"), "mine");
  EXPECT_EQ(test::read_file(out / "old.old-h-4-5" / "a.txt"), "mine");

  // remove_own_files: the same rule, and a temporary directory loses only insid's files.
  fs::create_directories(killed_dir);
  ASSERT_TRUE(mark_as_temporary(killed_dir));
  write_file_atomic(killed_dir / "imu.csv", "t\n");
  std::ofstream(killed_dir / "notes.txt") << "mine";
  std::vector<fs::path> kept = remove_own_files(out);
  std::sort(kept.begin(), kept.end());
  const std::vector<fs::path> expected = {killed_dir.filename() / "notes.txt", "list.tmp-h-1-2",
                                          "old.old-h-4-5/a.txt", "photos.tmp-laptop-12-3/img1.jpg"};
  std::vector<fs::path> sorted_expected = expected;
  std::sort(sorted_expected.begin(), sorted_expected.end());
  EXPECT_EQ(kept, sorted_expected);
  EXPECT_FALSE(fs::exists(killed_dir / "imu.csv"));
  EXPECT_EQ(test::read_file(killed_dir / "notes.txt"), "mine");
}

// A rerun removes what a killed process of this host left beside its target (a
// dataset's temporary directory), never a live process's or another host's.
TEST_F(OutputDir, AbandonedSiblingsOfADeadProcessAreRemoved) {
  if (!supported_) GTEST_SKIP() << root_ << ": no user extended attributes on this file system";
  const fs::path target = root_ / "ds";
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // a "killed simulate": its temporary directory, marked, then gone
    const fs::path t = temporary_sibling(target, ".tmp-");
    fs::create_directories(t);
    mark_as_temporary(t);
    write_file_atomic(t / "imu.csv", "t\n");
    const std::string name = t.filename().string();
    (void)!::write(pipe_fds[1], name.data(), name.size());
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  std::array<char, 512> buffer{};
  const ssize_t n = ::read(pipe_fds[0], buffer.data(), buffer.size());
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_GT(n, 0);
  const fs::path dead = root_ / std::string(buffer.data(), static_cast<std::size_t>(n));
  ASSERT_TRUE(fs::exists(dead / "imu.csv"));
  const fs::path live = temporary_sibling(target, ".tmp-");  // this process: alive
  fs::create_directories(live);
  mark_as_temporary(live);
  const fs::path other_host = root_ / "ds.tmp-elsewhere-1-0";
  fs::create_directories(other_host);
  mark_as_temporary(other_host);
  const fs::path users = root_ / "ds.tmp-photos";
  fs::create_directories(users);

  EXPECT_EQ(remove_abandoned_siblings(target), 1);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other_host));
  EXPECT_TRUE(fs::exists(users));
}

TEST(OutputDirNames, ATemporaryLookingNameIsRefused) {
  for (const std::string name : {"x.tmp-host-1-2", "a.old-h-3-4", "run.tmp-"})
    EXPECT_THROW(checked_path_component(name, "scenario name"), std::invalid_argument) << name;
  EXPECT_EQ(checked_path_component("x.tmp", "scenario name"), "x.tmp");
}

}  // namespace
}  // namespace insid
