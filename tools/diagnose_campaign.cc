// insid-diagnose-campaign: the full hidden-effect matrix for `insid diagnose`:
// effects x sizes x seeds on the `rich` preset, effect-free seeds (false alarms), pairs of
// separable effects, and effects the `straight` preset cannot observe. One JSON line per case in
// OUT/cases.jsonl (resumable: cases already there are skipped), then OUT/summary.json with the
// confusion matrix and detection power per size. Figures: scripts/diagnose_campaign_report.py.
// `--matrix mems`: MEMS grade, windowed fitness (--windows), rich / racetrack /
// multicopter, scored on names *and sizes* (a case is right only if the truth is named, its class
// first, and its estimate lies within 3 sd + 10 % of the injected value), and a second scoring
// of the detectable cases by whether the truth is separable from its collinear class
// (diagnose/campaign_scoring.h; `size_scoring.separability`).
#include <algorithm>
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
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "base/json_reader.h"
#include "base/number_text.h"
#include "diagnose/campaign_scoring.h"
#include "diagnose/diagnose.h"
#include "diagnose/hidden_effects.h"
#include "tools/tool_main.h"

namespace {

using json = nlohmann::json;
using insid::number_text;
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

// The extended matrix adds effects the original one lacks: accel_scale_z (easily named
// as another effect), a second gyro misalignment and a gyro_bias_z drift.
std::vector<Nominal> extended_effects() {
  std::vector<Nominal> e = nominal_effects();
  e.push_back({"accel_scale_z", 500e-6, "500 ppm"});
  e.push_back({"gyro_misalign_zx", 200e-6, "200 urad"});
  e.push_back({"gyro_bias_drift_z", 1.0 * kDegH / 3600.0, "1 deg/h per hour"});
  return e;
}

// The MEMS / windowed matrix: latency, the three lever arms, scale factors,
// misalignments and bias drifts, at sizes a MEMS unit can have. Effect-free 600 s MEMS flights
// (seed 77, W = 10 and 20 s) put diagnose's minimum detectable sizes (95 % power) at: latency
// 10-14 ms on rich and multicopter, 90-100 ms on racetrack; lever arms 0.1-0.15 m on
// multicopter, 0.2-0.3 m on rich, 2.1-2.9 m on racetrack; so the same physical size is clearly
// detectable on one flight and below the limit of another. Every case records the truth's own
// minimum detectable size and the summary scores the two kinds apart.
std::vector<Nominal> mems_effects() {
  return {{"gnss_latency", 0.1, "100 ms"},
          {"lever_arm_x", 1.0, "1 m"},
          {"lever_arm_y", 1.0, "1 m"},
          {"lever_arm_z", 1.0, "1 m"},
          {"gyro_scale_z", 3000e-6, "3000 ppm"},
          {"accel_scale_x", 10000e-6, "10000 ppm"},
          {"accel_scale_z", 5000e-6, "5000 ppm"},
          {"gyro_misalign_xy", 3e-3, "3 mrad"},
          {"gyro_misalign_zx", 20e-3, "20 mrad"},
          {"gyro_bias_drift_z", 0.2 * std::numbers::pi / 180.0 / 3600.0, "0.2 deg/s per hour"},
          {"accel_bias_drift_x", 0.2 / 3600.0, "0.2 m/s^2 per hour"}};
}

// Wilson score interval for k successes in n trials (95 %: z = 1.96).
std::pair<double, double> wilson(int k, int n, double z = 1.959963984540054) {
  if (n == 0) return {0.0, 1.0};
  const double p = static_cast<double>(k) / n, z2 = z * z, den = 1.0 + z2 / n;
  const double centre = (p + z2 / (2.0 * n)) / den;
  const double half = z * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / den;
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

struct Case {
  std::string kind;  // null | single | pair | unobservable
  HiddenCase data;
  double size_factor = 1.0;
  bool key_has_flight = false;  // extended matrix: nulls of one seed at two lengths
  double window_s = 0.0;        // mems matrix: the windowed fitness's W (0 = one run)
  std::string key() const {
    std::ostringstream s;
    s << kind << "|" << data.preset << "|" << data.seed << "|" << size_factor;
    if (key_has_flight) s << "|" << data.flight_s << "s";
    if (data.grade != "nav") s << "|" << data.grade << "|W=" << window_s;
    for (const auto& [n, v] : data.hidden) s << "|" << n << "=" << v;
    return s.str();
  }
};

// Every case of OUT/cases.jsonl (empty lines skipped), each line through insid's strict JSON
// reader and its limits; an error names the file and the line. A missing file has no cases.
std::vector<json> read_cases(const std::filesystem::path& path) {
  std::vector<json> rows;
  std::ifstream in(path);
  std::size_t line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty()) continue;
    const std::string where = path.string() + " line " + std::to_string(line_no);
    json row = insid::parse_json_strict(line, where);
    if (!row.is_object() || !row.contains("key") || !row["key"].is_string())
      throw std::runtime_error(where + ": expected a case object with a string \"key\"");
    rows.push_back(std::move(row));
  }
  return rows;
}

int run_campaign(int argc, char** argv);

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-diagnose-campaign", [&] { return run_campaign(argc, argv); });
}

namespace {

// The command line of insid-diagnose-campaign, with its defaults.
struct CampaignArgs {
  std::string out_dir = "results/diagnose";
  double flight_s = 1200.0;
  int seeds = 2, null_seeds = 24, threads = 0, iterations = 5, rb = 30, rc = 60;
  std::vector<double> sizes = {0.1, 0.25, 0.5, 1.0};
  bool summary_only = false;
  std::string matrix = "original";
  std::vector<double> null_flights = {600.0, 1200.0};
  std::vector<std::string> null_presets = {"rich", "racetrack", "straight"};
  std::string family_calibration = "replica-max";
  std::vector<std::string> presets = {"rich", "racetrack", "multicopter"};
  std::vector<double> windows = {10.0, 20.0};
};

CampaignArgs parse_args(int argc, char** argv) {
  CampaignArgs args;
  CLI::App app{"Full hidden-effect matrix for insid diagnose -> confusion matrix, power curves.",
               "insid-diagnose-campaign"};
  app.add_option("--out-dir", args.out_dir)->capture_default_str();
  app.add_option("--flight-s", args.flight_s)->capture_default_str();
  app.add_option("--seeds", args.seeds, "seeds per effect and size")->capture_default_str();
  app.add_option("--null-seeds", args.null_seeds, "effect-free seeds")->capture_default_str();
  app.add_option("--sizes", args.sizes, "size factors of the nominal hidden sizes");
  app.add_option("--threads", args.threads)->capture_default_str();
  app.add_option("--iterations", args.iterations, "optimizer iterations")->capture_default_str();
  app.add_option("--replicas-basis", args.rb)->capture_default_str();
  app.add_option("--replicas-calibration", args.rc)->capture_default_str();
  app.add_option("--family-calibration", args.family_calibration,
                 "replica-max (Westfall-Young, default) | gaussian (a normal-theory family rule)")
      ->capture_default_str();
  app.add_flag("--summary-only", args.summary_only, "only rebuild summary.json from cases.jsonl");
  app.add_option("--matrix", args.matrix,
                 "original: the first case list (results/diagnose/); extended: 11 "
                 "effects x --sizes x --seeds on rich --flight-s, --null-seeds per preset and null "
                 "flight length, interleaved so that any prefix is balanced; mems: MEMS grade, "
                 "11 effects x --sizes x --seeds x --presets x --windows at --flight-s, "
                 "--null-seeds per preset and window, level+heading alignment, interleaved")
      ->check(CLI::IsMember({"original", "extended", "mems"}))
      ->capture_default_str();
  app.add_option("--null-flights", args.null_flights, "extended: null flight lengths (s)");
  app.add_option("--null-presets", args.null_presets, "extended: null presets");
  app.add_option("--presets", args.presets, "mems: the presets (nulls and effects)");
  app.add_option("--windows", args.windows, "mems: the fitness windows W (s)");
  insid::tools::parse(app, argc, argv);
  return args;
}

// The hidden effects and their nominal sizes of a --matrix.
std::vector<Nominal> matrix_effects(const std::string& matrix) {
  return matrix == "extended" ? extended_effects()
         : matrix == "mems"   ? mems_effects()
                              : nominal_effects();
}

// The campaign's cases in run order (the matrix's own interleaving: a campaign stopped early is
// balanced).
std::vector<Case> case_list(const CampaignArgs& args, const std::vector<Nominal>& effects) {
  std::vector<Case> cases;
  if (args.matrix == "mems") {
    // Round r: ceil(null_seeds / seeds) null seeds (5001, ...), each flown on every preset and
    // judged at every W, then every preset x effect x size x W at seed 7000 + r; so a campaign
    // stopped early is balanced between nulls, presets, effects and windows.
    const int per_round = (args.null_seeds + std::max(args.seeds, 1) - 1) / std::max(args.seeds, 1);
    int next_null = 1;
    auto mems_case = [&](std::string kind, std::string preset, unsigned seed,
                         std::map<std::string, double> hidden, double f, double w) {
      Case c{
          std::move(kind), {std::move(preset), args.flight_s, seed, std::move(hidden), "mems"}, f};
      c.window_s = w;
      return c;
    };
    for (int r = 1; next_null <= args.null_seeds || r <= args.seeds; ++r) {
      for (int k = 0; k < per_round && next_null <= args.null_seeds; ++k, ++next_null)
        for (const std::string& preset : args.presets)
          for (double w : args.windows)
            cases.push_back(
                mems_case("null", preset, 5000u + static_cast<unsigned>(next_null), {}, 0, w));
      if (r <= args.seeds)
        for (const Nominal& e : effects)
          for (const std::string& preset : args.presets)
            for (double f : args.sizes)
              for (double w : args.windows)
                cases.push_back(mems_case("single", preset, 7000u + static_cast<unsigned>(r),
                                          {{e.effect, f * e.value}}, f, w));
    }
  }
  if (args.matrix == "extended") {
    // Round r: ceil(null_seeds / seeds) null seeds, one flight per preset and length each
    // (seeds 5001, ...), then every effect at every size (seed 6000 + r); so a campaign stopped
    // early is balanced between nulls and effects.
    const int per_round = (args.null_seeds + std::max(args.seeds, 1) - 1) / std::max(args.seeds, 1);
    int next_null = 1;
    for (int r = 1; next_null <= args.null_seeds || r <= args.seeds; ++r) {
      for (int k = 0; k < per_round && next_null <= args.null_seeds; ++k, ++next_null)
        for (const std::string& preset : args.null_presets)
          for (double len : args.null_flights)
            cases.push_back(
                {"null", {preset, len, 5000u + static_cast<unsigned>(next_null), {}}, 0, true});
      if (r <= args.seeds)
        for (const Nominal& e : effects)
          for (double f : args.sizes)
            cases.push_back({"single",
                             {"rich",
                              args.flight_s,
                              6000u + static_cast<unsigned>(r),
                              {{e.effect, f * e.value}}},
                             f,
                             true});
    }
  }
  for (int s = 1; args.matrix == "original" && s <= args.null_seeds; ++s)
    cases.push_back({"null", {"rich", args.flight_s, 1000u + s, {}}, 0});
  for (const Nominal& e : nominal_effects())
    for (double f : args.sizes)
      for (int s = 1; args.matrix == "original" && s <= args.seeds; ++s)
        cases.push_back(
            {"single", {"rich", args.flight_s, 2000u + s, {{e.effect, f * e.value}}}, f});
  for (int s = 1; args.matrix == "original" && s <= args.seeds; ++s) {
    cases.push_back(
        {"pair",
         {"rich", args.flight_s, 3000u + s, {{"gnss_latency", 0.05}, {"gyro_scale_z", 300e-6}}},
         1});
    cases.push_back(
        {"pair",
         {"rich", args.flight_s, 3100u + s, {{"lever_arm_z", 0.5}, {"accel_scale_x", 2000e-6}}},
         1});
    cases.push_back(
        {"unobservable", {"straight", args.flight_s, 4000u + s, {{"lever_arm_x", 1.0}}}, 1});
    cases.push_back(
        {"unobservable", {"straight", args.flight_s, 4100u + s, {{"lever_arm_y", 1.0}}}, 1});
    cases.push_back({"null", {"straight", args.flight_s, 4200u + s, {}}, 0});
  }
  return cases;
}

// One line of cases.jsonl: the case, what diagnose found, and what re-judging it needs.
json case_record(const Case& c, const insid::diagnose::DiagnoseResult& res, double wall) {
  json j;
  j["key"] = c.key();
  j["kind"] = c.kind;
  j["preset"] = c.data.preset;
  j["seed"] = c.data.seed;
  j["flight_s"] = c.data.flight_s;
  j["size_factor"] = c.size_factor;
  j["hidden"] = c.data.hidden;
  j["grade"] = c.data.grade;
  j["window_s"] = c.window_s;
  j["found"] = res.report["found"];
  j["withdrawn"] = res.report["withdrawn"];  // the backward check's withdrawals
  j["not_observable"] = res.report["not_observable"];
  j["gap"] = res.report["gap"];
  j["noise_floor"] = res.report["noise_floor"];
  j["threshold_z"] = res.report["iterations"][0]["threshold_z"];
  j["top"] = res.report["iterations"][0]["candidates"][0];
  // What re-judging the first iteration under either family-wise rule needs
  // (every candidate's row, both thresholds, the replicas' own max |z|).
  {
    const json& i0 = res.report["iterations"][0];
    j["family_calibration"] = i0["family_calibration"];
    j["threshold_z_gaussian"] = i0["threshold_z_gaussian"];
    j["threshold_z_replica_max"] = i0["threshold_z_replica_max"];
    j["replica_max_z"] = i0["replica_max_z"];
    j["first_candidates"] = i0["candidates"];
    j["first_choice"] = i0["choice"];
  }
  // The hidden effects' own rows in the first table (z, min detectable size).
  for (const auto& [name, v] : c.data.hidden)
    for (const auto& row : res.report["iterations"][0]["candidates"])
      if (row["effect"] == name) j["hidden_rows"][name] = row;
  j["wall_s"] = wall;
  return j;
}

// Runs every case not yet in cases.jsonl (by key) and appends its line, one at a time (a
// campaign stopped anywhere resumes where it stopped).
void run_missing_cases(const std::vector<Case>& cases, const CampaignArgs& args,
                       const std::filesystem::path& cases_path) {
  std::set<std::string> done;
  for (const json& row : read_cases(cases_path)) done.insert(row["key"].get<std::string>());
  std::ofstream out(cases_path, std::ios::app);
  int k = 0;
  for (const Case& c : cases) {
    ++k;
    if (done.count(c.key())) continue;
    const auto t0 = std::chrono::steady_clock::now();
    auto ds = insid::diagnose::make_hidden_dataset(c.data);
    insid::diagnose::DiagnoseOptions o;
    o.seed = c.data.seed;
    o.optimizer_iterations = args.iterations;
    o.replicas_basis = args.rb;
    o.replicas_calibration = args.rc;
    o.threads = args.threads;
    o.max_effects = 3;
    o.family_calibration = args.family_calibration;
    o.grade = &insid::sensor_grade(c.data.grade);
    o.window_s = c.window_s;
    // MEMS gyros cannot gyrocompass (insid refuses it): level + the GNSS course, as a user
    // of a MEMS log would run it.
    if (c.data.grade == "mems") o.initial_attitude.mode = insid::InitialAttitudeMode::kLevelHeading;
    const auto res = insid::diagnose::run_diagnose(ds, o);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const json j = case_record(c, res, wall);
    out << j.dump() << "\n" << std::flush;
    std::string f;
    for (const auto& x : res.found) f += x + " ";
    std::fprintf(stderr, "[%d/%zu] %s -> found: %s(shrink %.2f, %.1f s)\n", k, cases.size(),
                 c.key().c_str(), f.c_str(), res.shrink, wall);
  }
}

// The named entry `f` is `name` or names it among its ambiguity partners.
bool in_class(const json& f, const std::string& name) {
  if (f["effect"] == name) return true;
  for (const auto& a : f["ambiguous_with"])
    if (a == name) return true;
  return false;
}

// The original matrix's summary: false alarms on the nulls, the confusion matrix (hidden effect ->
// first named effect), detection power per size (the class and the exact effect), the shrink of the
// gap at the nominal size, pairs and unobservable effects.
void add_first_named_summary(const std::vector<json>& rows, const std::vector<Nominal>& effects,
                             json& summary) {
  json nominal = json::object();
  for (const Nominal& e : effects) nominal[e.effect] = {{"value", e.value}, {"label", e.label}};
  summary["nominal"] = nominal;
  std::map<std::string, std::map<std::string, int>> confusion;        // hidden -> named -> count
  std::map<std::string, std::map<double, std::array<int, 3>>> power;  // hit(class), exact, n
  std::map<std::string, std::vector<double>> shrinks;
  int null_n = 0, null_fa = 0, straight_null_n = 0, straight_null_fa = 0;
  int unobs_n = 0, unobs_reported = 0, unobs_named = 0;
  int pair_n = 0, pair_both = 0;
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
  summary["false_alarm"] = {{"rich_seeds", null_n},
                            {"rich_with_found", null_fa},
                            {"rate", null_n ? static_cast<double>(null_fa) / null_n : 0.0},
                            {"straight_seeds", straight_null_n},
                            {"straight_with_found", straight_null_fa}};
  summary["confusion"] = confusion;
  json pj = json::object();
  for (const auto& [h, by] : power)
    for (const auto& [f, c] : by)
      pj[h].push_back({{"size_factor", f},
                       {"size", f * nominal[h]["value"].get<double>()},
                       {"detected_class", c[0]},
                       {"detected_exact", c[1]},
                       {"n", c[2]}});
  summary["power"] = pj;
  json sj = json::object();
  for (const auto& [h, v] : shrinks) {
    double mn = 1e9, mean = 0;
    for (double x : v) mn = std::min(mn, x), mean += x;
    sj[h] = {{"min", mn}, {"mean", mean / v.size()}, {"n", v.size()}};
  }
  summary["shrink_at_nominal"] = sj;
  summary["pairs"] = {{"n", pair_n}, {"both_found", pair_both}};
  summary["unobservable"] = {
      {"n", unobs_n}, {"reported_not_observable", unobs_reported}, {"named", unobs_named}};
}

// The extended summary: every null flight (any preset, any length), the rate with its 95 % Wilson
// interval, and the confusion of the first named effect with the ambiguity sets counted
// separately: "(none)", the effect alone (unambiguous), or "{a, b, ...}" (named + partners).
void add_null_and_set_summary(const std::vector<json>& rows, json& summary) {
  std::map<std::string, std::array<int, 2>> by_flight;  // "preset/len s" -> named, n
  int n_all = 0, fa_all = 0;
  std::map<std::string, std::map<std::string, int>> sets;               // hidden -> label -> count
  std::map<std::string, std::map<double, std::array<int, 5>>> outcome;  // see below
  auto label = [](const json& found) {
    if (found.empty()) return std::string("(none)");
    const json& f = found[0];
    if (f["ambiguous_with"].empty()) return f["effect"].get<std::string>();
    std::set<std::string> members = {f["effect"].get<std::string>()};
    for (const auto& a : f["ambiguous_with"]) members.insert(a.get<std::string>());
    std::string l = "{";
    for (const auto& m : members) l += (l.size() > 1 ? ", " : "") + m;
    return l + "}";
  };
  for (const json& r : rows) {
    const std::string kind = r["kind"];
    const json& found = r["found"];
    if (kind == "null") {
      std::ostringstream k;
      k << r["preset"].get<std::string>() << "/" << r["flight_s"].get<double>() << " s";
      auto& b = by_flight[k.str()];
      b[0] += !found.empty();
      b[1]++;
      fa_all += !found.empty();
      ++n_all;
      sets["(none)"][label(found)]++;
    } else if (kind == "single") {
      const std::string h = r["hidden"].begin().key();
      const double f = r["size_factor"];
      sets[h + " x" + number_text(f, 6)][label(found)]++;
      // exact and unambiguous, truth in the first named set, named set (any iteration)
      // contains the truth, first named wrong, nothing named
      auto& o = outcome[h][f];
      if (found.empty()) {
        o[4]++;
        continue;
      }
      const bool exact = found[0]["effect"] == h && found[0]["ambiguous_with"].empty();
      o[0] += exact;
      o[1] += !exact && in_class(found[0], h);
      bool any = false;
      for (const auto& x : found) any = any || in_class(x, h);
      o[2] += any;
      o[3] += !in_class(found[0], h);
    }
  }
  const auto [lo, hi] = wilson(fa_all, n_all);
  json fj = {{"null_flights", n_all},
             {"with_found", fa_all},
             {"rate", n_all ? static_cast<double>(fa_all) / n_all : 0.0},
             {"wilson95", {lo, hi}}};
  for (const auto& [k, b] : by_flight) {
    const auto [l2, h2] = wilson(b[0], b[1]);
    fj["by_flight"][k] = {{"n", b[1]}, {"with_found", b[0]}, {"wilson95", {l2, h2}}};
  }
  summary["false_alarm_all"] = fj;
  summary["confusion_sets"] = sets;
  json oj = json::object();
  for (const auto& [h, by] : outcome)
    for (const auto& [f, o] : by)
      oj[h].push_back({{"size_factor", f},
                       {"exact_unambiguous", o[0]},
                       {"first_set_contains_truth", o[1]},
                       {"named_set_contains_truth", o[2]},
                       {"first_named_wrong", o[3]},
                       {"nothing_named", o[4]},
                       {"n", o[0] + o[1] + o[3] + o[4]}});
  summary["outcome"] = oj;
}

// The MEMS summary: names *and sizes*. A single case is right when the truth's class is named first
// and the truth itself is named (any iteration) with |estimate - injected| <= 3 sd + 10 % of
// the injected value; "strict" also needs the truth to be the first name. Wrong first: the
// first name's class does not hold the truth ("unflagged": and it carries no ambiguity flag).
// Grouped by preset, W, effect and size; nulls by preset and W. Rows without window_s
// (the original and extended matrices) have W = 0.
void add_size_scoring(const std::vector<json>& rows, json& summary) {
  auto window_of = [](const json& r) {
    return r.contains("window_s") ? r["window_s"].get<double>() : 0.0;
  };
  struct Tally {
    int n = 0, detectable = 0, right = 0, strict = 0, named = 0, wrong_first = 0,
        wrong_unflagged = 0, none = 0;
    std::vector<double> rel_error, z_error;  // (estimate - truth) / truth and / sd
  };
  std::map<std::string, Tally> groups;
  std::map<std::string, Tally> by_size;             // "size detectable|below_detection_limit"
  std::map<std::string, std::array<int, 2>> nulls;  // "preset W=w" -> named, n
  // The second scoring: detectable cases split by separability from the truth's
  // collinear class.
  struct SepTally {
    int n = 0, right = 0, strict = 0;
    std::array<int, 5> first{};  // by insid::diagnose::FirstName
  };
  std::map<std::string, std::map<std::string, SepTally>> sep_by_size, sep_by_effect;
  // Cases with a partner: whole class recorded, classification changed by it, not recorded.
  std::array<int, 3> class_check{};
  int sep_no_row = 0;
  for (const json& r : rows) {
    std::ostringstream where;
    where << r["preset"].get<std::string>() << " W=" << window_of(r);
    const json& found = r["found"];
    if (r["kind"] == "null") {
      auto& b = nulls[where.str()];
      b[0] += !found.empty();
      b[1]++;
      continue;
    }
    if (r["kind"] != "single") continue;
    const std::string h = r["hidden"].begin().key();
    const double truth = r["hidden"].begin().value().get<double>();
    const double f = r["size_factor"];
    // The truth's own minimum detectable size on this flight (95 % power, the first
    // iteration's row): at or above it the case is "detectable", below it the flight cannot
    // be expected to tell (and naming the effect with a wrong size is still wrong). The second
    // scoring: "separable" when the size is also detectable with the truth's most correlated
    // collinear partner estimated jointly (diagnose/campaign_scoring.h).
    const bool has_row = r.contains("hidden_rows") && r["hidden_rows"].contains(h);
    const insid::diagnose::CaseLimits lim =
        insid::diagnose::case_limits(has_row ? r["hidden_rows"][h] : json(), truth);
    const bool detectable = lim.detectable;
    const std::string kind = detectable ? "detectable" : "below_detection_limit";
    // The truth's entry among the named effects, and right in name and size (the issue-33
    // rule), for both scorings.
    const json* entry = nullptr;
    for (const auto& x : found)
      if (x["effect"] == h) {
        entry = &x;
        break;
      }
    bool right = false, strict = false;
    if (entry != nullptr) {
      const double est = (*entry)["estimate"], sd = (*entry)["sd"];
      const bool size_ok = std::abs(est - truth) <= 3.0 * sd + 0.1 * std::abs(truth);
      right = in_class(found[0], h) && size_ok;
      strict = found[0]["effect"] == h && size_ok;
    }
    const std::string fs = number_text(f, 6);
    if (detectable && lim.has_row) {
      const std::string sep = lim.separable ? "separable" : "not_separable";
      for (SepTally* t : {&sep_by_size[fs][sep], &sep_by_effect[h + " x" + fs][sep]}) {
        ++t->n;
        t->right += right;
        t->strict += strict;
        t->first[static_cast<int>(insid::diagnose::first_name(found, h))]++;
      }
      // The whole recorded class (where all its mutual correlations are recorded) against
      // the one-partner bound the definition uses; cases with a partner only.
      if (!lim.partner.empty() && r.contains("first_candidates")) {
        const double ci = insid::diagnose::class_inflation(r["first_candidates"], h);
        if (std::isfinite(ci)) {
          ++class_check[0];
          class_check[1] += (std::abs(truth) >= lim.min_detectable * ci) != lim.separable;
        } else {
          ++class_check[2];
        }
      }
    } else if (detectable) {
      ++sep_no_row;
    }
    for (Tally* t : {&groups[where.str() + " " + h + " x" + fs], &by_size[fs + " " + kind]}) {
      ++t->n;
      t->detectable += detectable;
      if (found.empty()) {
        ++t->none;
        continue;
      }
      const bool class_first = in_class(found[0], h);
      t->wrong_first += !class_first;
      t->wrong_unflagged += !class_first && found[0]["ambiguous_with"].empty();
      if (entry == nullptr) continue;
      ++t->named;
      const double est = (*entry)["estimate"], sd = (*entry)["sd"];
      t->right += right;
      t->strict += strict;
      t->rel_error.push_back((est - truth) / truth);
      t->z_error.push_back(sd > 0 ? (est - truth) / sd : 0.0);
    }
  }
  auto tally_json = [](const Tally& t) {
    const auto [lo, hi] = wilson(t.right, t.n);
    json j = {{"n", t.n},
              {"detectable", t.detectable},
              {"right", t.right},
              {"right_wilson95", {lo, hi}},
              {"right_strict", t.strict},
              {"named", t.named},
              {"first_named_wrong", t.wrong_first},
              {"first_named_wrong_unflagged", t.wrong_unflagged},
              {"nothing_named", t.none}};
    if (!t.rel_error.empty()) {
      std::vector<double> rel = t.rel_error, z = t.z_error;
      std::sort(rel.begin(), rel.end());
      std::sort(z.begin(), z.end());
      j["median_relative_error"] = rel[rel.size() / 2];
      j["median_error_in_sd"] = z[z.size() / 2];
      j["max_abs_error_in_sd"] = std::max(std::abs(z.front()), std::abs(z.back()));
    }
    return j;
  };
  json sz = json::object();
  sz["rule"] =
      "right: truth's class named first, truth named, |estimate - injected| <= 3 sd + 10 % "
      "of injected; strict: truth named first";
  for (const auto& [k, t] : groups) sz["groups"][k] = tally_json(t);
  for (const auto& [k, t] : by_size) sz["by_size_factor"][k] = tally_json(t);
  int fa = 0, nn = 0;
  for (const auto& [k, b] : nulls) {
    const auto [lo, hi] = wilson(b[0], b[1]);
    sz["nulls"][k] = {{"n", b[1]}, {"with_found", b[0]}, {"wilson95", {lo, hi}}};
    fa += b[0];
    nn += b[1];
  }
  const auto [lo, hi] = wilson(fa, nn);
  sz["nulls_all"] = {{"n", nn}, {"with_found", fa}, {"wilson95", {lo, hi}}};
  using insid::diagnose::FirstName;
  auto sep_json = [](const SepTally& t) {
    const auto [l2, h2] = wilson(t.right, t.n);
    return json{
        {"n", t.n},
        {"right", t.right},
        {"right_wilson95", {l2, h2}},
        {"right_strict", t.strict},
        {"truth_first", t.first[static_cast<int>(FirstName::kTruth)]},
        {"truth_in_flagged_first_set", t.first[static_cast<int>(FirstName::kTruthInFlaggedSet)]},
        {"wrong_first_flagged", t.first[static_cast<int>(FirstName::kWrongFlagged)]},
        {"wrong_first_unflagged", t.first[static_cast<int>(FirstName::kWrongUnflagged)]},
        {"nothing_named", t.first[static_cast<int>(FirstName::kNothing)]}};
  };
  json sep = json::object();
  sep["rule"] =
      "among detectable cases: separable when |injected| >= the truth's minimum detectable "
      "size alone x 1/sqrt(1 - rho^2), rho the largest |correlation| of a recorded collinear "
      "partner (|rho| > 0.95) in the truth's first-iteration row; a lower bound of the "
      "inflation with the whole class, so it errs towards separable. right: as above; "
      "truth_first / truth_in_flagged_first_set / wrong_first_flagged / "
      "wrong_first_unflagged / nothing_named: the first name";
  for (const auto& [k, by] : sep_by_size)
    for (const auto& [s2, t] : by) sep["by_size_factor"][k][s2] = sep_json(t);
  for (const auto& [k, by] : sep_by_effect)
    for (const auto& [s2, t] : by) sep["by_effect"][k][s2] = sep_json(t);
  sep["detectable_without_row"] = sep_no_row;
  sep["class_check"] = {{"class_recorded", class_check[0]},
                        {"classification_changed", class_check[1]},
                        {"class_not_recorded", class_check[2]}};
  sz["separability"] = sep;
  summary["size_scoring"] = sz;
}

int run_campaign(int argc, char** argv) {
  const CampaignArgs args = parse_args(argc, argv);
  namespace fs = std::filesystem;
  fs::create_directories(args.out_dir);
  const fs::path cases_path = fs::path(args.out_dir) / "cases.jsonl";
  const std::vector<Nominal> effects = matrix_effects(args.matrix);
  const std::vector<Case> cases = case_list(args, effects);
  if (!args.summary_only) run_missing_cases(cases, args, cases_path);

  // Summary: confusion matrix (hidden effect -> first named effect / its class), power.
  const std::vector<json> rows = read_cases(cases_path);
  json summary;
  summary["flight_s"] = args.flight_s;
  add_first_named_summary(rows, effects, summary);
  add_null_and_set_summary(rows, summary);
  add_size_scoring(rows, summary);
  double wall = 0;
  for (const json& r : rows) wall += r["wall_s"].get<double>();
  summary["cases"] = rows.size();
  summary["total_wall_s"] = wall;
  std::ofstream(fs::path(args.out_dir) / "summary.json") << summary.dump(2) << "\n";
  std::cout << summary.dump(2) << "\n";
  return 0;
}

}  // namespace
