// The progress printer (cli/progress.h): '\r' only on a terminal, plain lines at a bounded rate
// elsewhere, nothing with --quiet.
#include "cli/progress.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace insid::cli {
namespace {

// What a printer wrote to a temporary file.
class Captured {
 public:
  Captured() : file_(std::tmpfile()) {}
  ~Captured() { std::fclose(file_); }
  std::FILE* file() { return file_; }
  std::string text() {
    std::fflush(file_);
    std::rewind(file_);
    std::string out;
    for (int c; (c = std::fgetc(file_)) != EOF;) out += static_cast<char>(c);
    return out;
  }

 private:
  std::FILE* file_;
};

void feed(ProgressPrinter& p) {
  p.note("preparing scenario rich");
  for (int k = 1; k <= 50; ++k) p.status("runs " + std::to_string(k) + "/50");
  p.finish();
}

TEST(ProgressPrinter, TerminalRewritesOneLineWithCarriageReturns) {
  Captured out;
  {
    ProgressPrinter p("insid sweep", Verbosity::kNormal, out.file(), /*terminal=*/true);
    feed(p);
  }
  const std::string text = out.text();
  EXPECT_EQ(text.rfind("insid sweep: preparing scenario rich\n", 0), 0u) << text;
  EXPECT_NE(text.find("\rinsid sweep: runs 50/50"), std::string::npos) << text;
  // The notes line and the one live line, ended once by finish().
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2) << text;
}

TEST(ProgressPrinter, FileGetsPlainLinesAtABoundedRateAndTheLastOne) {
  Captured out;
  {
    // A long interval: only the first status and the last (held back, printed by finish).
    ProgressPrinter p("insid sweep", Verbosity::kNormal, out.file(), /*terminal=*/false, 3600.0);
    feed(p);
  }
  const std::string text = out.text();
  EXPECT_EQ(text.find('\r'), std::string::npos) << text;
  EXPECT_EQ(text,
            "insid sweep: preparing scenario rich\n"
            "insid sweep: runs 1/50\n"
            "insid sweep: runs 50/50\n");
}

TEST(ProgressPrinter, VerboseFilePrintsEveryUpdate) {
  Captured out;
  {
    ProgressPrinter p("insid bench", Verbosity::kVerbose, out.file(), /*terminal=*/true, 3600.0);
    feed(p);
    p.detail("extra");
  }
  const std::string text = out.text();
  EXPECT_EQ(text.find('\r'), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1 + 50 + 1) << text;
  EXPECT_NE(text.find("insid bench: extra\n"), std::string::npos);
}

TEST(ProgressPrinter, QuietPrintsNothing) {
  for (bool terminal : {true, false}) {
    Captured out;
    {
      ProgressPrinter p("insid bench", Verbosity::kQuiet, out.file(), terminal);
      feed(p);
      p.detail("extra");
    }
    EXPECT_EQ(out.text(), "") << "terminal " << terminal;
  }
}

TEST(ProgressPrinter, ANoteEndsTheLiveLineFirst) {
  Captured out;
  {
    ProgressPrinter p("insid bench", Verbosity::kNormal, out.file(), /*terminal=*/true);
    p.status("runs 1/2");
    p.note("redoing a damaged run file");
    p.status("runs 2/2");
  }
  EXPECT_EQ(out.text(),
            "\rinsid bench: runs 1/2\ninsid bench: redoing a damaged run file\n"
            "\rinsid bench: runs 2/2\n");
}

}  // namespace
}  // namespace insid::cli
