// External optimizers over a pipe (external.h): the reference Python client equals the same
// random search computed directly with numpy; lock-step == separate runs; the protocol's message
// sequence; crashing, hanging and malformed clients give the documented errors and leave the
// other runs of a run_together() alone.
#include "optimizers/external.h"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "optimizers/registry.h"
#include "optimizers/test_functions.h"
#include "test_support/optimizer_runs.h"
#include "test_support/process.h"

namespace insid::opt {
namespace {
namespace fs = std::filesystem;

#define REQUIRE_PYTHON() \
  if (!test::python_with_numpy()) GTEST_SKIP() << test::kPython << " with numpy is not available"

// An asymmetric box: a swapped lower/upper or a dropped offset shows.
Bounds test_box() {
  Bounds box;
  box.lower = Eigen::Vector3d(-1.0, -2.0, 0.5);
  box.upper = Eigen::Vector3d(1.0, 3.0, 2.0);
  return box;
}

double bowl(const Eigen::VectorXd& x) {
  return (x - Eigen::Vector3d(0.3, -0.7, 1.1)).squaredNorm();
}

// The same random search computed directly: numpy's default_rng(seed), `count` uniform points
// in the box drawn at once (the client draws them `batch` at a time from the same stream).
std::vector<Eigen::VectorXd> numpy_points(std::uint64_t seed, const Bounds& box, int count) {
  const std::string script =
      "import json, numpy as np; "
      "p = np.random.default_rng(" +
      std::to_string(seed) + ").uniform(" + format_vector(box.lower) + ", " +
      format_vector(box.upper) + ", size=(" + std::to_string(count) + ", " +
      std::to_string(box.dimension()) +
      ")); "
      "print(json.dumps(p.tolist()))";
  const nlohmann::json j =
      nlohmann::json::parse(test::run_command(test::kPython + " -c '" + script + "'"));
  std::vector<Eigen::VectorXd> points;
  for (const auto& row : j) {
    Eigen::VectorXd x(box.dimension());
    for (int d = 0; d < box.dimension(); ++d) x[d] = row[static_cast<std::size_t>(d)].get<double>();
    points.push_back(x);
  }
  return points;
}

std::string client_algo(const std::string& extra = "") {
  return "external:" + test::kPython + " " + test::kExternalClient + extra;
}

TEST(External, PythonRandomSearchEqualsDirectComputation) {
  REQUIRE_PYTHON();
  const Bounds box = test_box();
  FunctionProblem problem(box, bowl);
  for (const std::uint64_t seed : {7u, 123456789u}) {
    RunConfig config;
    config.seed = seed;
    config.max_iterations = 0;
    config.max_evaluations = 47;  // 4 asks of 10, then the client asks for the remaining 7
    const Result result = optimize(client_algo(), problem, config);

    const std::vector<Eigen::VectorXd> points = numpy_points(seed, box, 47);
    ASSERT_EQ(points.size(), 47u);
    std::vector<double> best_per_evaluation;
    double best = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_x;
    for (const Eigen::VectorXd& x : points) {
      if (bowl(x) < best) {
        best = bowl(x);
        best_x = x;
      }
      best_per_evaluation.push_back(best);
    }
    EXPECT_EQ(result.evaluations, 47);
    EXPECT_EQ(result.iterations, 5);
    EXPECT_EQ(result.termination, Termination::kEvaluations);
    EXPECT_EQ(result.best_per_evaluation, best_per_evaluation) << "seed " << seed;
    EXPECT_TRUE(test::same(result.best_x, best_x))
        << format_vector(result.best_x) << " vs " << format_vector(best_x);
    EXPECT_EQ(result.best_f, best);
    EXPECT_EQ(result.history.back().batch_size, 7);
    EXPECT_EQ(result.parameters, (ParameterList{{"timeout_s", 60.0}}));
  }
}

TEST(External, LockStepEqualsSeparateRuns) {
  REQUIRE_PYTHON();
  const Bounds box = test_box();
  FunctionProblem problem(box, bowl);
  RunConfig config;
  config.max_iterations = 4;
  std::vector<std::unique_ptr<Optimizer>> together;
  std::vector<Optimizer*> pointers;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    config.seed = seed;
    // Different batch sizes per run: the shared batch has uneven slices.
    together.push_back(
        make_optimizer(client_algo(" --batch " + std::to_string(3 + seed)), box, config));
    pointers.push_back(together.back().get());
  }
  run_together(pointers, problem);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    config.seed = seed;
    const Result alone =
        optimize(client_algo(" --batch " + std::to_string(3 + seed)), problem, config);
    test::expect_same_run(together[seed - 1]->result(), alone);
    EXPECT_EQ(alone.evaluations, 4 * static_cast<std::int64_t>(3 + seed));
  }
}

TEST(External, MessagesFollowTheProtocol) {
  REQUIRE_PYTHON();
  const fs::path log =
      fs::temp_directory_path() / ("insid-external-log-" + std::to_string(getpid()));
  fs::remove(log);
  const Bounds box = test_box();
  FunctionProblem problem(box, bowl);
  RunConfig config;
  config.seed = 5;
  config.max_iterations = 0;
  config.max_evaluations = 5;  // 2 + 2 + (2 truncated to 1)
  {
    auto optimizer = make_optimizer(
        "external:" + test::kPython + " " + test::kExternalTestClient + " log " + log.string(), box,
        config);
    run(*optimizer, problem);
    EXPECT_EQ(optimizer->result().evaluations, 5);
  }  // destroyed: "stop" sent, the client exits
  std::ifstream in(log);
  std::vector<nlohmann::json> messages;
  for (std::string line; std::getline(in, line);) messages.push_back(nlohmann::json::parse(line));
  fs::remove(log);
  ASSERT_EQ(messages.size(), 7u);  // problem, ask, tell, ask, tell, ask (truncated: no tell), stop
  EXPECT_EQ(messages[0]["type"], "problem");
  EXPECT_EQ(messages[0]["protocol"], 1);
  EXPECT_EQ(messages[0]["dimension"], 3);
  EXPECT_EQ(messages[0]["lower"], nlohmann::json({-1.0, -2.0, 0.5}));
  EXPECT_EQ(messages[0]["upper"], nlohmann::json({1.0, 3.0, 2.0}));
  EXPECT_EQ(messages[0]["seed"], 5);
  EXPECT_EQ(messages[0]["max_evaluations"], 5);
  EXPECT_EQ(messages[0]["max_iterations"], 0);
  const std::vector<std::string> types = {"problem", "ask", "tell", "ask", "tell", "ask", "stop"};
  for (std::size_t i = 0; i < types.size(); ++i) EXPECT_EQ(messages[i]["type"], types[i]) << i;
  EXPECT_EQ(messages[1]["iteration"], 1);
  EXPECT_EQ(messages[1]["remaining_evaluations"], 5);
  EXPECT_EQ(messages[5]["remaining_evaluations"], 1);
  // The tell carries the fitness of the points asked: the centre, then the lower corner.
  const Eigen::Vector3d centre(0.0, 0.5, 1.25), lower(-1.0, -2.0, 0.5);
  EXPECT_EQ(messages[2]["fitness"], nlohmann::json({bowl(centre), bowl(lower)}));
  EXPECT_EQ(messages[6]["reason"], "evaluations");
}

// Runs a misbehaving client alone; returns the error message (or "" when it did not fail).
std::string error_of(const std::string& mode, double timeout_s = 60.0) {
  const Bounds box = test_box();
  FunctionProblem problem(box, bowl);
  RunConfig config;
  config.seed = 11;
  config.max_iterations = 5;
  try {
    optimize("external:" + test::kPython + " " + test::kExternalTestClient + " " + mode, problem,
             config, {{"timeout_s", timeout_s}});
  } catch (const ExternalOptimizerError& e) {
    return e.what();
  }
  return "";
}

void expect_contains(const std::string& text, const std::string& part) {
  EXPECT_NE(text.find(part), std::string::npos) << "'" << part << "' not in: " << text;
}

TEST(External, CrashingClientNamesItsExitStatus) {
  REQUIRE_PYTHON();
  const std::string e = error_of("crash");
  expect_contains(e, "external optimizer '" + test::kPython + " " + test::kExternalTestClient +
                         " crash' (seed 11)");
  expect_contains(e, "the process exited with status 3 before replying to ask 2");
}

TEST(External, HangingClientIsKilledAfterTheTimeout) {
  REQUIRE_PYTHON();
  const auto t0 = std::chrono::steady_clock::now();
  const std::string e = error_of("hang", 0.5);
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  expect_contains(e,
                  "(seed 11): no reply to ask 1 within timeout_s = 0.5 s; killed (was killed "
                  "by signal 9)");
  EXPECT_LT(waited, 10.0);
}

TEST(External, MalformedRepliesNameTheLine) {
  REQUIRE_PYTHON();
  expect_contains(error_of("notjson"),
                  "reply to ask 1 (line 1 of its output) 'this is not json': not valid JSON: ");
  expect_contains(error_of("dimension"),
                  "reply to ask 1 (line 1 of its output) '{\"points\": [[0.0, 0.5, 1.25], [0.0, "
                  "0.5, 1.25, 0.0]]}': points[1]: expected an array of 3 numbers, found an array "
                  "[0.0,0.5,1.25,0.0]");
  expect_contains(error_of("outside"),
                  "reply to ask 1 (line 1 of its output) '{\"points\": [[2.0, 4.0, 3.0]]}': "
                  "points[0][0]: expected a number in the box [-1, 1], found 2");
  expect_contains(error_of("giveup"), "(seed 11): gave up at ask 1: no idea what to do");
}

TEST(External, HostilyDeepReplyIsRefusedAtTheDepthLimit) {
  // 100000 nested arrays crashed insid (SIGSEGV: a recursive dump of the
  // deepest value); 10000 and 30000 gave a message. Every depth now stops at the reader's limit.
  REQUIRE_PYTHON();
  for (const int depth : {65, 10000, 100000}) {
    const std::string e = error_of("deep " + std::to_string(depth));
    expect_contains(e, "(seed 11): reply to ask 1 (line 1 of its output) '{\"points\": [[[[");
    expect_contains(e,
                    ": line 1, column 75 (byte 74): nesting depth 65 exceeds the limit of 64 "
                    "nested arrays and objects");
  }
  // Within the limit (the reply object is depth 1): an ordinary complaint about the point.
  expect_contains(error_of("deep 63"),
                  "': points[0]: expected an array of 3 numbers, found an array [[[[");
}

TEST(External, ReplyNobodyAskedForIsRefused) {
  // A client that replies twice per ask was read one ask late (its second
  // reply to ask 1 taken as the reply to ask 2). The protocol is one reply line per ask.
  REQUIRE_PYTHON();
  expect_contains(error_of("twice"),
                  "(seed 11): line 2 of its output '{\"points\": [[0.0, 0.5, 1.25]]}' answers "
                  "no ask (it follows its reply to ask 1; the protocol is one reply line per "
                  "ask)");
}

TEST(External, ReplyParserReadsPointsOrNamesWhatIsWrong) {
  // The reply reader alone (fuzz/external_reply_fuzzer.cc fuzzes it).
  const Bounds box = test_box();
  const ExternalReply r =
      parse_external_reply(R"({"points": [[0, 0.5, 1], [1, 3, 2]]})", box, "r ");
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_FALSE(r.error);
  EXPECT_EQ(r.points[1], Eigen::Vector3d(1.0, 3.0, 2.0));
  EXPECT_EQ(*parse_external_reply(R"({"error": {"why": 1}})", box, "r ").error, R"({"why":1})");
  const auto error = [&](const std::string& line) {
    try {
      parse_external_reply(line, box, "r ");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  // The one typed reader's wording (base/json_object.h): the line, the field's path, what was
  // expected and what was found.
  // an unknown key, with the valid ones
  EXPECT_EQ(error(R"({"points": [[0, 0, 1]], "best": 1})"),
            "r '{\"points\": [[0, 0, 1]], \"best\": 1}': best: unknown key (valid keys: points, "
            "error)");
  // a missing key
  EXPECT_EQ(error(R"({})"), "r '{}': points: missing, expected an array");
  // wrong types
  EXPECT_EQ(error(R"({"points": [[0, "x", 1]]})"),
            "r '{\"points\": [[0, \"x\", 1]]}': points[0][1]: expected a finite number, found a "
            "string \"x\"");
  EXPECT_EQ(error(R"({"points": {"a": 1}})"),
            "r '{\"points\": {\"a\": 1}}': points: expected an array, found an object {\"a\":1}");
  EXPECT_EQ(error(R"({"points": [[0, 0, 1], 5]})"),
            "r '{\"points\": [[0, 0, 1], 5]}': points[1]: expected an array of 3 numbers, found a "
            "number 5");
  EXPECT_EQ(error("[]"), "r '[]': expected an object, found an array []");
  // a key given twice (refused by the strict parser, in the same wording)
  EXPECT_EQ(error(R"({"points": [[0, 0, 1]], "points": []})"),
            "r '{\"points\": [[0, 0, 1]], \"points\": []}': points: key given twice in one "
            "object (JSON objects must not repeat a key)");
  // values
  EXPECT_EQ(error(R"({"points": []})"),
            "r '{\"points\": []}': points: expected at least one point, found an empty array");
  EXPECT_EQ(error(R"({"points": [[0, 3.5, 1]]})"),
            "r '{\"points\": [[0, 3.5, 1]]}': points[0][1]: expected a number in the box [-2, 3], "
            "found 3.5");
}

TEST(External, FailedRunLeavesTheOthersAlone) {
  REQUIRE_PYTHON();
  const Bounds box = test_box();
  FunctionProblem problem(box, bowl);
  RunConfig config;
  config.seed = 3;
  config.max_iterations = 4;
  std::vector<std::unique_ptr<Optimizer>> runs;
  runs.push_back(make_optimizer(client_algo(), box, config));
  runs.push_back(make_optimizer(
      "external:" + test::kPython + " " + test::kExternalTestClient + " crash", box, config));
  runs.push_back(make_optimizer("pso", box, config));
  runs.push_back(make_optimizer(
      "external:" + test::kPython + " " + test::kExternalTestClient + " notjson", box, config));
  std::vector<Optimizer*> pointers;
  for (auto& r : runs) pointers.push_back(r.get());
  std::map<std::size_t, std::string> failures;
  TogetherHooks hooks;
  hooks.failed = [&](std::size_t i, std::exception_ptr error) {
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      failures[i] = e.what();
    }
  };
  run_together(pointers, problem, hooks);
  ASSERT_EQ(failures.size(), 2u);
  expect_contains(failures[1], "exited with status 3 before replying to ask 2");
  expect_contains(failures[3], "not valid JSON");
  test::expect_same_run(runs[0]->result(), optimize(client_algo(), problem, config));
  test::expect_same_run(runs[2]->result(), optimize("pso", problem, config));
}

TEST(External, BadNamesAndParameters) {
  RunConfig config;
  EXPECT_THROW(make_optimizer("external:", test_box(), config), std::invalid_argument);
  EXPECT_THROW(make_optimizer("external:  ", test_box(), config), std::invalid_argument);
  EXPECT_THROW(make_optimizer("external:true", test_box(), config, {{"timeout_s", 0.0}}),
               std::invalid_argument);
  EXPECT_THROW(make_optimizer("external:true", test_box(), config, {{"population", 3.0}}),
               std::invalid_argument);
  // The constructor starts nothing (campaign configs are validated by constructing).
  const auto optimizer = make_optimizer("external:exit 1", test_box(), config);
  EXPECT_EQ(default_parameters("external:anything"), (ParameterList{{"timeout_s", 60.0}}));
}

}  // namespace
}  // namespace insid::opt
