#include "base/json_reader.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace insid {
namespace {

std::string error_of(const std::string& text) {
  try {
    parse_json_strict(text, "cfg.json");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(JsonReader, AcceptsJsonAndKeepsEveryValue) {
  const nlohmann::json j =
      parse_json_strict(R"({"a": 1, "b": {"a": 2, "c": [{"a": 3}, {"a": 4}]}, "d": 1e308})", "x");
  EXPECT_EQ(j["a"], 1);
  EXPECT_EQ(j["b"]["c"][1]["a"], 4);
  EXPECT_EQ(j["d"].get<double>(), 1e308);
  // The same key in different objects is not a duplicate.
  EXPECT_NO_THROW(parse_json_strict(R"([{"k": 1}, {"k": 2}, {"x": {"k": 3}, "k": 4}])", "x"));
}

TEST(JsonReader, KeyGivenTwiceIsNamedWithItsPath) {
  // The typed reader's wording (base/json_object.h): source, path of the field, what is wrong.
  EXPECT_EQ(error_of(R"({"seeds": 3, "name": "a", "seeds": 5})"),
            "cfg.json: seeds: key given twice in one object (JSON objects must not repeat a key)");
  EXPECT_EQ(
      error_of(R"({"scenarios": [{"name": "a"}, {"name": "b", "grade": "nav", "grade": "mems"}]})"),
      "cfg.json: scenarios[1].grade: key given twice in one object (JSON objects must not repeat "
      "a key)");
  EXPECT_NE(
      error_of(R"({"a": {"b": [[1], {"c": {"d": 1, "d": 2}}]}})").find("cfg.json: a.b[1].c.d: "),
      std::string::npos);
}

TEST(JsonReader, SyntaxErrorsAndOverflowsAreRuntimeErrorsWithTheLine) {
  EXPECT_NE(error_of("{\n\"a\": 1,\n}").find("cfg.json: not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("{\n\"a\": 1,\n}").find("line 3"), std::string::npos);
  // nlohmann's internal tag is not shown
  EXPECT_EQ(error_of("{\n\"a\": 1,\n}").find("json.exception"), std::string::npos)
      << error_of("{\n\"a\": 1,\n}");
  EXPECT_EQ(error_of(R"({"a": 1e999})").find("json.exception"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": NaN})").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": 1e999})").find("number overflow"), std::string::npos);
  EXPECT_NE(error_of("").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": 1} trailing)").find("not valid JSON"), std::string::npos);
  // nlohmann's parser stops at a NUL byte: the strict reader refuses it (found by
  // fuzz/json_fuzzer.cc).
  EXPECT_EQ(error_of(std::string("{\"a\": 1}\0{\"b\": [", 18)),
            "cfg.json: line 1, column 9 (byte 8): a NUL byte, which JSON text never holds (not "
            "valid JSON)");
  EXPECT_NE(error_of(std::string("[\"a\0\"]", 6)).find("(byte 3): a NUL byte"), std::string::npos);
}

TEST(JsonReader, FileErrorsNameTheFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("insid-json-test-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  try {
    read_json_file(dir / "missing.json");
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json: cannot open"), std::string::npos);
  }
  try {
    read_json_file(dir);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos);
  }
  std::ofstream(dir / "dup.json") << R"({"x": 1, "x": 2})";
  try {
    read_json_file(dir / "dup.json", "--config dup.json");
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--config dup.json: x: key given twice", 0), 0u)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(JsonReader, NestingBeyondTheDepthLimitIsRefusedNamingTheLimit) {
  // insid's own files nest at most 8 deep (results/*/summary.json); the limit is 64.
  const auto nested = [](std::size_t depth) {
    return std::string(depth, '[') + std::string(depth, ']');
  };
  EXPECT_NO_THROW(parse_json_strict(nested(kJsonMaxDepth), "x"));
  EXPECT_EQ(error_of(nested(kJsonMaxDepth + 1)),
            "cfg.json: line 1, column 65 (byte 64): nesting depth 65 exceeds the limit of 64 "
            "nested arrays and objects");
  // Inside an object, on a later line, with brackets inside strings not counted.
  EXPECT_EQ(error_of("{\"a\": \"[[{\",\n \"b\": " + std::string(100, '[')),
            "cfg.json: line 2, column 70 (byte 82): nesting depth 65 exceeds the limit of 64 "
            "nested arrays and objects");
  // A caller's tighter limit.
  try {
    parse_json_strict(R"({"points": [[[1]]]})", "reply", {.max_depth = 3});
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(),
                 "reply: line 1, column 14 (byte 13): nesting depth 4 exceeds the limit of 3 "
                 "nested arrays and objects");
  }
}

// Runs `parse` in a child process under an address-space limit of `headroom_bytes` above its
// size at the start; returns the child's peak resident memory growth (bytes) and the outcome:
// the error message, "(accepted)", or "(bad_alloc escaped)". The test process is not put at risk.
struct ChildParse {
  long peak_growth_bytes = -1;
  std::string outcome;
};
template <class Parse>
ChildParse parse_in_child(Parse parse, std::size_t headroom_bytes) {
  int fds[2];
  if (::pipe(fds) != 0) return {};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    std::size_t vm_bytes = 0;
    if (FILE* f = std::fopen("/proc/self/statm", "r")) {
      std::size_t pages = 0;
      if (std::fscanf(f, "%zu", &pages) == 1) vm_bytes = pages * ::sysconf(_SC_PAGESIZE);
      std::fclose(f);
    }
    const rlimit limit{vm_bytes + headroom_bytes, vm_bytes + headroom_bytes};
    ::setrlimit(RLIMIT_AS, &limit);
    rusage before{}, after{};
    ::getrusage(RUSAGE_SELF, &before);
    std::string outcome;
    try {
      parse();
      outcome = "(accepted)";
    } catch (const std::runtime_error& e) {
      outcome = e.what();
    } catch (const std::bad_alloc&) {
      outcome = "(bad_alloc escaped)";
    }
    ::getrusage(RUSAGE_SELF, &after);
    const std::string report =
        std::to_string((after.ru_maxrss - before.ru_maxrss) * 1024L) + "\n" + outcome;
    (void)!::write(fds[1], report.data(), report.size());
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string report;
  char buffer[4096];
  for (ssize_t n; (n = ::read(fds[0], buffer, sizeof buffer)) > 0;)
    report.append(buffer, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ChildParse out;
  const std::size_t eol = report.find('\n');
  if (eol == std::string::npos) {
    out.outcome = "(child ended without a report, wait status " + std::to_string(status) + ")";
    return out;
  }
  out.peak_growth_bytes = std::stol(report.substr(0, eol));
  out.outcome = report.substr(eol + 1);
  return out;
}

TEST(JsonReader, HostileNestingCostsNoMemory) {
  // 200 KB of nested '[' took 87 s and 17.9 GB before the depth was bounded
  // (the path of every open array was kept, quadratic in the depth). Now it stops at depth 65.
  const std::string hostile = std::string(100000, '[') + std::string(100000, ']');
  const ChildParse r =
      parse_in_child([&] { parse_json_strict(hostile, "meta.json"); }, std::size_t{1} << 30);
  EXPECT_EQ(r.outcome.rfind("meta.json: line 1, column 65 (byte 64): nesting depth 65", 0), 0u)
      << r.outcome;
  EXPECT_GE(r.peak_growth_bytes, 0);
  EXPECT_LT(r.peak_growth_bytes, 16L << 20) << "peak resident growth " << r.peak_growth_bytes;
}

TEST(JsonReader, DocumentBeyondTheSizeLimitIsRefusedNamingTheFile) {
  EXPECT_EQ(kJsonMaxBytes, std::size_t{64} << 20);
  try {
    parse_json_strict(std::string(101, ' ') + "1", "cfg.json", {.max_bytes = 100});
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(),
                 "cfg.json: 102 bytes, more than the limit of 100 bytes of a JSON "
                 "document");
  }
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("insid-json-size-" + std::to_string(getpid()) + ".json");
  std::ofstream(path) << "[" << std::string(2000, ' ') << "]";
  try {
    read_json_file(path, "--config big.json", {.max_bytes = 1000});
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(),
                 "--config big.json: 2002 bytes, more than the limit of 1000 bytes of "
                 "a JSON document");
  }
  std::filesystem::remove(path);
}

TEST(JsonReader, OutOfMemoryNamesTheDocument) {
  // Within both limits, but the parser's copy of the 30 MB string does not fit the child's
  // 40 MiB: the error names the document instead of a bare std::bad_alloc.
  const std::string big = "[\"" + std::string(30000000, 'x') + "\"]";
  const ChildParse r =
      parse_in_child([&] { parse_json_strict(big, "meta.json"); }, std::size_t{40} << 20);
  EXPECT_EQ(r.outcome,
            "meta.json: out of memory parsing a JSON document of 30000004 bytes (its parsed "
            "value takes many times its size)");
}

}  // namespace
}  // namespace insid
