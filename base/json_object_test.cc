#include "base/json_object.h"

#include <functional>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "base/json_reader.h"

namespace insid {
namespace {

using json = nlohmann::json;

// The message of the JsonFieldError `read` throws, or "(accepted)".
std::string error_of(const std::function<void()>& read) {
  try {
    read();
  } catch (const JsonFieldError& e) {
    return e.what();
  }
  return "(accepted)";
}

const json kDocument = json::parse(R"({
  "name": "c",
  "rate_hz": 100,
  "gain": 0.5,
  "on": true,
  "count": 3.0,
  "tags": ["a", "b"],
  "values": [1, 2.5],
  "imu": {"rate_hz": 200, "axes": [{"bias": 1}, {"bias": 2}]},
  "set": {"x": 1, "y": 2}
})");

const std::vector<std::string> kKeys = {"name", "rate_hz", "gain", "on",  "count",
                                        "tags", "values",  "imu",  "set", "absent"};

TEST(JsonObject, ReadsEveryTypeAtItsPath) {
  const JsonObject r = JsonObject::document(kDocument, "c.json", kKeys);
  EXPECT_EQ(r.string("name"), "c");
  EXPECT_EQ(r.number("rate_hz"), 100.0);
  EXPECT_EQ(r.field("gain").number(), 0.5);
  EXPECT_TRUE(r.field("on").boolean());
  EXPECT_EQ(r.field("count").integer(0, 10), 3);
  EXPECT_EQ(r.array("tags").strings(), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(r.array("values").numbers(), (std::vector<double>{1.0, 2.5}));
  const JsonObject imu = r.object("imu", {"rate_hz", "axes"});
  EXPECT_EQ(imu.path(), "imu");
  EXPECT_EQ(imu.number("rate_hz"), 200.0);
  const JsonArray axes = imu.array("axes");
  ASSERT_EQ(axes.size(), 2u);
  const JsonObject axis = axes[1].object({"bias"});
  EXPECT_EQ(axis.path(), "imu.axes[1]");
  EXPECT_EQ(axis.number("bias"), 2.0);
  // A map: any keys, sorted by key.
  const JsonObject set = r.field("set").map();
  std::vector<std::string> names;
  for (const auto& item : set.value().items()) names.push_back(item.key());
  EXPECT_EQ(names, (std::vector<std::string>{"x", "y"}));
  EXPECT_EQ(set.number("y"), 2.0);
  // Optional fields and fallbacks.
  EXPECT_FALSE(r.has("absent"));
  EXPECT_FALSE(r.optional("absent"));
  EXPECT_FALSE(r.optional_number("absent"));
  EXPECT_EQ(r.number("absent", 7.0), 7.0);
  EXPECT_EQ(r.string("absent", "x"), "x");
  EXPECT_EQ(*r.optional_number("gain"), 0.5);
}

TEST(JsonObject, UnknownKeyIsRefusedListingTheValidOnes) {
  const json j = json::parse(R"({"scenarios": [{"name": "a"}, {"name": "b", "colour": 1}]})");
  const JsonObject top = JsonObject::document(j, "campaign.json", {"scenarios"});
  EXPECT_EQ(error_of([&] {
              top.array("scenarios")[1].object({"name", "preset", "data"});
            }),
            "campaign.json: scenarios[1].colour: unknown key (valid keys: name, preset, data)");
  EXPECT_EQ(error_of([&] { JsonObject::document(j, "campaign.json", {"name"}); }),
            "campaign.json: scenarios: unknown key (valid keys: name)");
  // A map takes any key.
  EXPECT_EQ(error_of([&] { top.array("scenarios")[1].map(); }), "(accepted)");
  // So does an object that leaves other keys alone, but it reads only its own.
  const JsonObject open =
      JsonObject::with_other_keys(j["scenarios"][1], "campaign.json", "scenarios[1]", {"name"});
  EXPECT_EQ(open.string("name"), "b");
  EXPECT_THROW((void)open.has("colour"), std::logic_error);
}

TEST(JsonObject, MissingKeyNamesThePathAndTheExpectedType) {
  const json j = json::parse(R"({"imu": {"noise": {}}})");
  const JsonObject noise = JsonObject::document(j, "c.json", {"imu"})
                               .object("imu", {"noise"})
                               .object("noise", {"arw", "grade", "on", "n", "list", "sub"});
  EXPECT_EQ(error_of([&] { noise.number("arw"); }),
            "c.json: imu.noise.arw: missing, expected a finite number");
  EXPECT_EQ(error_of([&] { noise.string("grade"); }),
            "c.json: imu.noise.grade: missing, expected a string");
  EXPECT_EQ(error_of([&] { noise.field("on").boolean(); }),
            "c.json: imu.noise.on: missing, expected a boolean");
  EXPECT_EQ(error_of([&] { noise.field("n").integer(1, 9); }),
            "c.json: imu.noise.n: missing, expected a whole number in [1, 9]");
  EXPECT_EQ(error_of([&] { noise.array("list"); }),
            "c.json: imu.noise.list: missing, expected an array");
  EXPECT_EQ(error_of([&] { noise.object("sub", {}); }),
            "c.json: imu.noise.sub: missing, expected an object");
}

TEST(JsonObject, WrongTypeSaysWhatWasExpectedAndWhatWasFound) {
  const json j = json::parse(
      R"({"scenarios": [{}, {"imu": {"rate_hz": "x", "on": 1, "n": 2.5, "m": -1,
          "name": 3, "list": {"a": [1, 2]}, "sub": [1, 2], "v": [1, "2"], "mode": "fast",
          "long": "0123456789012345678901234567890123456789012345678901234567890123456789",
          "nothing": null}}]})");
  const JsonObject imu = JsonObject::document(j, "campaign.json", {"scenarios"})
                             .array("scenarios")[1]
                             .object({"imu"})
                             .object("imu", {"rate_hz", "on", "n", "m", "name", "list", "sub", "v",
                                             "mode", "long", "nothing"});
  EXPECT_EQ(error_of([&] { imu.number("rate_hz"); }),
            "campaign.json: scenarios[1].imu.rate_hz: expected a finite number, found a string "
            "\"x\"");
  EXPECT_EQ(error_of([&] { imu.field("rate_hz").number(); }),
            "campaign.json: scenarios[1].imu.rate_hz: expected a number, found a string \"x\"");
  EXPECT_EQ(error_of([&] { imu.field("on").boolean(); }),
            "campaign.json: scenarios[1].imu.on: expected a boolean, found a number 1");
  EXPECT_EQ(error_of([&] { imu.field("n").integer(0, 10); }),
            "campaign.json: scenarios[1].imu.n: expected a whole number in [0, 10], found a "
            "number 2.5");
  EXPECT_EQ(error_of([&] { imu.field("m").integer(0, 10); }),
            "campaign.json: scenarios[1].imu.m: expected a whole number in [0, 10], found a "
            "number -1");
  EXPECT_EQ(error_of([&] { imu.string("name"); }),
            "campaign.json: scenarios[1].imu.name: expected a string, found a number 3");
  EXPECT_EQ(error_of([&] { imu.array("list"); }),
            "campaign.json: scenarios[1].imu.list: expected an array, found an object "
            "{\"a\":[1,2]}");
  EXPECT_EQ(error_of([&] { imu.object("sub", {}); }),
            "campaign.json: scenarios[1].imu.sub: expected an object, found an array [1,2]");
  EXPECT_EQ(error_of([&] { imu.array("v").numbers(); }),
            "campaign.json: scenarios[1].imu.v[1]: expected a finite number, found a string "
            "\"2\"");
  EXPECT_EQ(error_of([&] {
              imu.field("mode").choice({"slow", "steady"});
            }),
            "campaign.json: scenarios[1].imu.mode: expected \"slow\" or \"steady\", found a "
            "string \"fast\"");
  EXPECT_EQ(error_of([&] {
              imu.field("mode").choice({"slow", "steady", "still"});
            }),
            "campaign.json: scenarios[1].imu.mode: expected one of \"slow\", \"steady\", "
            "\"still\", found a string \"fast\"");
  EXPECT_EQ(imu.field("mode").choice({"slow", "fast"}), "fast");
  EXPECT_EQ(error_of([&] { imu.string("nothing"); }),
            "campaign.json: scenarios[1].imu.nothing: expected a string, found null");
  // A long value is cut.
  EXPECT_EQ(error_of([&] { imu.number("long"); }),
            "campaign.json: scenarios[1].imu.long: expected a finite number, found a string "
            "\"01234567890123456789012345678901234567890123456789012345678...");
  // The top level has no path.
  EXPECT_EQ(error_of([&] { JsonObject::document(json::parse("[1, 2]"), "c.json", {}); }),
            "c.json: expected an object, found an array [1,2]");
}

TEST(JsonObject, NonFiniteNumberOfAnInMemoryValueIsRefusedWhereFiniteIsExpected) {
  // Only an in-memory value can hold NaN (the strict parser refuses it in text).
  json j;
  j["x"] = std::nan("");
  const JsonObject r = JsonObject::document(j, "preset p", {"x"});
  EXPECT_TRUE(std::isnan(r.field("x").number()));
  EXPECT_EQ(error_of([&] { r.number("x"); }),
            "preset p: x: expected a finite number, found a number nan");
}

TEST(JsonObject, KeyGivenTwiceComesThroughWithItsPath) {
  const auto parse_error = [](const std::string& text) {
    try {
      parse_json_strict(text, "campaign.json");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(parse_error(R"({"scenarios": [{"name": "a"}, {"imu": {"rate_hz": 1, "rate_hz": 2}}]})"),
            "campaign.json: scenarios[1].imu.rate_hz: key given twice in one object (JSON "
            "objects must not repeat a key)");
  EXPECT_EQ(parse_error(R"({"seeds": 1, "seeds": 2})"),
            "campaign.json: seeds: key given twice in one object (JSON objects must not repeat "
            "a key)");
}

TEST(JsonObject, FailNamesTheObjectOrItsField) {
  const json j = json::parse(R"({"imu": {"rate_hz": -1}})");
  const JsonObject imu = JsonObject::document(j, "c.json", {"imu"}).object("imu", {"rate_hz"});
  EXPECT_EQ(error_of([&] { imu.fail("rate_hz", "must be > 0, found -1"); }),
            "c.json: imu.rate_hz: must be > 0, found -1");
  EXPECT_EQ(error_of([&] { imu.fail("give a rate"); }), "c.json: imu: give a rate");
  EXPECT_EQ(error_of([&] { imu.field("rate_hz").fail("too low"); }),
            "c.json: imu.rate_hz: too low");
  // The errors are invalid_argument (a config is an argument).
  EXPECT_THROW(imu.fail("x"), std::invalid_argument);
}

TEST(JsonObject, ReadingAnUndeclaredKeyIsAProgrammingError) {
  // The declared keys are the valid keys messages name: every key read must be among them.
  // (JsonFieldError is an invalid_argument, itself a logic_error: caught first, it fails.)
  const JsonObject r = JsonObject::document(json::parse(R"({"a": 1})"), "c.json", {"a"});
  const auto kind_of = [](const std::function<void()>& read) {
    try {
      read();
    } catch (const JsonFieldError&) {
      return std::string("JsonFieldError");
    } catch (const std::logic_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(kind_of([&] { r.number("b"); }),
            "c.json: b: read but not among the object's declared keys");
  EXPECT_EQ(kind_of([&] { (void)r.has("b"); }),
            "c.json: b: read but not among the object's declared keys");
}

}  // namespace
}  // namespace insid
