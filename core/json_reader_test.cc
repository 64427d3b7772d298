#include "core/json_reader.h"

#include <unistd.h>

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

TEST(JsonReader, KeyGivenTwiceIsNamedWithItsObject) {
  EXPECT_EQ(error_of(R"({"seeds": 3, "name": "a", "seeds": 5})"),
            "cfg.json: key \"seeds\" appears twice in the top-level object (JSON objects must not "
            "repeat a key)");
  EXPECT_NE(
      error_of(R"({"scenarios": [{"name": "a"}, {"name": "b", "grade": "nav", "grade": "mems"}]})")
          .find("key \"grade\" appears twice in object \"scenarios[1]\""),
      std::string::npos);
  EXPECT_NE(
      error_of(R"({"a": {"b": [[1], {"c": {"d": 1, "d": 2}}]}})").find("in object \"a.b[1].c\""),
      std::string::npos);
}

TEST(JsonReader, SyntaxErrorsAndOverflowsAreRuntimeErrorsWithTheLine) {
  EXPECT_NE(error_of("{\n\"a\": 1,\n}").find("cfg.json: not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("{\n\"a\": 1,\n}").find("line 3"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": NaN})").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": 1e999})").find("number overflow"), std::string::npos);
  EXPECT_NE(error_of("").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of(R"({"a": 1} trailing)").find("not valid JSON"), std::string::npos);
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
    EXPECT_EQ(std::string(e.what()).rfind("--config dup.json: key \"x\" appears twice", 0), 0u)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace insid
