// insid-diagnose-campaign: the full hidden-effect matrix for `insid diagnose` (issue 7):
// effects x sizes x seeds on the `rich` preset, effect-free seeds (false alarms), pairs of
// separable effects, and effects the `straight` preset cannot observe. One JSON line per case in
// OUT/cases.jsonl (resumable: cases already there are skipped), then OUT/summary.json with the
// confusion matrix and detection power per size. Figures: scripts/diagnose_campaign_report.py.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "diagnose/diagnose.h"
#include "diagnose/hidden_effects.h"

namespace {

using json = nlohmann::json;
using insid::diagnose::HiddenCase;

constexpr double kDegH = std::numbers::pi / 180.0 / 3600.0;  // deg/h -> rad/s

struct Nominal {
  std::string effect;
  double value;  // SI
  std::string label;
};

// Nominal hidden sizes (clearly detectable on a 1200 s `rich` flight; diagnose/README.md).
std::vector<Nominal> nominal_effects() {
  return {{"gnss_latency", 0.05, "50 ms"},
          {"lever_arm_x", 1.0, "1 m"},
          {"lever_arm_z", 0.5, "0.5 m"},
          {"gyro_bias_z", 0.3 * kDegH, "0.3 deg/h"},
          {"gyro_scale_z", 300e-6, "300 ppm"},
          {"accel_scale_x", 2000e-6, "2000 ppm"},
          {"gyro_misalign_xy", 200e-6, "200 urad"},
          {"accel_bias_drift_x", 10.0 * 0.0005 / 3600.0, "0.005 m/s^2 per hour"}};
}

struct Case {
  std::string kind;  // null | single | pair | unobservable
  HiddenCase data;
  double size_factor = 1.0;
  std::string key() const {
    std::ostringstream s;
    s << kind << "|" << data.preset << "|" << data.seed << "|" << size_factor;
    for (const auto& [n, v] : data.hidden) s << "|" << n << "=" << v;
    return s.str();
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Full hidden-effect matrix for insid diagnose -> confusion matrix, power curves."};
  std::string out_dir = "results/diagnose";
  double flight_s = 1200.0;
  int seeds = 2, null_seeds = 24, threads = 0, iterations = 5, rb = 30, rc = 60;
  std::vector<double> sizes = {0.1, 0.25, 0.5, 1.0};
  bool summary_only = false;
  app.add_option("--out-dir", out_dir)->capture_default_str();
  app.add_option("--flight-s", flight_s)->capture_default_str();
  app.add_option("--seeds", seeds, "seeds per effect and size")->capture_default_str();
  app.add_option("--null-seeds", null_seeds, "effect-free seeds")->capture_default_str();
  app.add_option("--sizes", sizes, "size factors of the nominal hidden sizes");
  app.add_option("--threads", threads)->capture_default_str();
  app.add_option("--iterations", iterations, "optimizer iterations")->capture_default_str();
  app.add_option("--replicas-basis", rb)->capture_default_str();
  app.add_option("--replicas-calibration", rc)->capture_default_str();
  app.add_flag("--summary-only", summary_only, "only rebuild summary.json from cases.jsonl");
  CLI11_PARSE(app, argc, argv);

  namespace fs = std::filesystem;
  fs::create_directories(out_dir);
  const fs::path cases_path = fs::path(out_dir) / "cases.jsonl";

  std::vector<Case> cases;
  for (int s = 1; s <= null_seeds; ++s) cases.push_back({"null", {"rich", flight_s, 1000u + s, {}}, 0});
  for (const Nominal& e : nominal_effects())
    for (double f : sizes)
      for (int s = 1; s <= seeds; ++s)
        cases.push_back({"single", {"rich", flight_s, 2000u + s, {{e.effect, f * e.value}}}, f});
  for (int s = 1; s <= seeds; ++s) {
    cases.push_back({"pair", {"rich", flight_s, 3000u + s,
                              {{"gnss_latency", 0.05}, {"gyro_scale_z", 300e-6}}}, 1});
    cases.push_back({"pair", {"rich", flight_s, 3100u + s,
                              {{"lever_arm_z", 0.5}, {"accel_scale_x", 2000e-6}}}, 1});
    cases.push_back({"unobservable", {"straight", flight_s, 4000u + s, {{"lever_arm_x", 1.0}}}, 1});
    cases.push_back({"unobservable", {"straight", flight_s, 4100u + s, {{"lever_arm_y", 1.0}}}, 1});
    cases.push_back({"null", {"straight", flight_s, 4200u + s, {}}, 0});
  }

  std::set<std::string> done;
  {
    std::ifstream in(cases_path);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) done.insert(json::parse(line)["key"].get<std::string>());
  }
  if (!summary_only) {
    std::ofstream out(cases_path, std::ios::app);
    int k = 0;
    for (const Case& c : cases) {
      ++k;
      if (done.count(c.key())) continue;
      const auto t0 = std::chrono::steady_clock::now();
      auto ds = insid::diagnose::make_hidden_dataset(c.data);
      insid::diagnose::DiagnoseOptions o;
      o.seed = c.data.seed;
      o.optimizer_iterations = iterations;
      o.replicas_basis = rb;
      o.replicas_calibration = rc;
      o.threads = threads;
      o.max_effects = 3;
      const auto res = insid::diagnose::run_diagnose(ds, o);
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      json j;
      j["key"] = c.key();
      j["kind"] = c.kind;
      j["preset"] = c.data.preset;
      j["seed"] = c.data.seed;
      j["flight_s"] = c.data.flight_s;
      j["size_factor"] = c.size_factor;
      j["hidden"] = c.data.hidden;
      j["found"] = res.report["found"];
      j["not_observable"] = res.report["not_observable"];
      j["gap"] = res.report["gap"];
      j["noise_floor"] = res.report["noise_floor"];
      j["threshold_z"] = res.report["iterations"][0]["threshold_z"];
      j["top"] = res.report["iterations"][0]["candidates"][0];
      // The hidden effects' own rows in the first table (z, min detectable size).
      for (const auto& [name, v] : c.data.hidden)
        for (const auto& row : res.report["iterations"][0]["candidates"])
          if (row["effect"] == name) j["hidden_rows"][name] = row;
      j["wall_s"] = wall;
      out << j.dump() << "\n" << std::flush;
      std::string f;
      for (const auto& x : res.found) f += x + " ";
      std::fprintf(stderr, "[%d/%zu] %s -> found: %s(shrink %.2f, %.1f s)\n", k, cases.size(),
                   c.key().c_str(), f.c_str(), res.shrink, wall);
    }
  }

  // Summary: confusion matrix (hidden effect -> first named effect / its class), power.
  std::vector<json> rows;
  {
    std::ifstream in(cases_path);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) rows.push_back(json::parse(line));
  }
  json summary;
  summary["flight_s"] = flight_s;
  json nominal = json::object();
  for (const Nominal& e : nominal_effects()) nominal[e.effect] = {{"value", e.value}, {"label", e.label}};
  summary["nominal"] = nominal;
  std::map<std::string, std::map<std::string, int>> confusion;  // hidden -> named -> count
  std::map<std::string, std::map<double, std::array<int, 3>>> power;  // hit(class), exact, n
  std::map<std::string, std::vector<double>> shrinks;
  int null_n = 0, null_fa = 0, straight_null_n = 0, straight_null_fa = 0;
  int unobs_n = 0, unobs_reported = 0, unobs_named = 0;
  int pair_n = 0, pair_both = 0;
  auto in_class = [](const json& f, const std::string& name) {
    if (f["effect"] == name) return true;
    for (const auto& a : f["ambiguous_with"])
      if (a == name) return true;
    return false;
  };
  for (const json& r : rows) {
    const std::string kind = r["kind"];
    const json& found = r["found"];
    if (kind == "null") {
      const bool fa = !found.empty();
      if (r["preset"] == "rich") {
        ++null_n;
        null_fa += fa;
        confusion["(none)"][fa ? found[0]["effect"].get<std::string>() : "(none)"]++;
      } else {
        ++straight_null_n;
        straight_null_fa += fa;
      }
    } else if (kind == "single") {
      const std::string h = r["hidden"].begin().key();
      const double f = r["size_factor"];
      auto& p = power[h][f];
      p[2]++;
      if (!found.empty()) {
        p[0] += in_class(found[0], h);
        p[1] += found[0]["effect"] == h;
      }
      if (f == 1.0) {
        confusion[h][found.empty() ? "(none)" : found[0]["effect"].get<std::string>()]++;
        if (r["gap"]["shrink"].is_number()) shrinks[h].push_back(r["gap"]["shrink"]);
      }
    } else if (kind == "pair") {
      ++pair_n;
      bool all = true;
      for (const auto& [h, v] : r["hidden"].items()) {
        bool hit = false;
        for (const auto& f : found) hit = hit || in_class(f, h);
        all = all && hit;
      }
      pair_both += all;
    } else if (kind == "unobservable") {
      ++unobs_n;
      const std::string h = r["hidden"].begin().key();
      bool reported = false, named = false;
      for (const auto& n : r["not_observable"]) reported = reported || n == h;
      for (const auto& f : found) named = named || in_class(f, h);
      unobs_reported += reported;
      unobs_named += named;
    }
  }
  summary["false_alarm"] = {{"rich_seeds", null_n}, {"rich_with_found", null_fa},
                            {"rate", null_n ? static_cast<double>(null_fa) / null_n : 0.0},
                            {"straight_seeds", straight_null_n},
                            {"straight_with_found", straight_null_fa}};
  summary["confusion"] = confusion;
  json pj = json::object();
  for (const auto& [h, by] : power)
    for (const auto& [f, c] : by)
      pj[h].push_back({{"size_factor", f}, {"size", f * nominal[h]["value"].get<double>()},
                       {"detected_class", c[0]}, {"detected_exact", c[1]}, {"n", c[2]}});
  summary["power"] = pj;
  json sj = json::object();
  for (const auto& [h, v] : shrinks) {
    double mn = 1e9, mean = 0;
    for (double x : v) mn = std::min(mn, x), mean += x;
    sj[h] = {{"min", mn}, {"mean", mean / v.size()}, {"n", v.size()}};
  }
  summary["shrink_at_nominal"] = sj;
  summary["pairs"] = {{"n", pair_n}, {"both_found", pair_both}};
  summary["unobservable"] = {{"n", unobs_n}, {"reported_not_observable", unobs_reported},
                             {"named", unobs_named}};
  double wall = 0;
  for (const json& r : rows) wall += r["wall_s"].get<double>();
  summary["cases"] = rows.size();
  summary["total_wall_s"] = wall;
  std::ofstream(fs::path(out_dir) / "summary.json") << summary.dump(2) << "\n";
  std::cout << summary.dump(2) << "\n";
  return 0;
}
