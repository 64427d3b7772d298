// IOHprofiler export of a campaign and its reader (iohprofiler.h).
#include "bench/iohprofiler.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "base/json_reader.h"
#include "base/number_text.h"
#include "bench/campaign.h"
#include "data/dataset.h"

namespace insid::campaign {
namespace fs = std::filesystem;
namespace {

// A header value inside single quotes: no quote or comma may appear in it (IOHanalyzer splits
// the line at commas and strips quotes).
std::string header_safe(std::string text) {
  for (char& c : text) {
    if (c == '\'' || c == '"') c = '`';
    if (c == ',') c = ';';
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split(const std::string& s, char separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == separator) {
      parts.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return parts;
}

[[noreturn]] void bad(const std::string& path, int line, const std::string& what) {
  throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
}

double parse_double(const std::string& text, const std::string& path, int line,
                    const std::string& what) {
  std::string t = trim(text);
  if (!t.empty() && t[0] == '+') t.erase(0, 1);  // "+2.95000e+02", as in the format's examples
  double value = 0.0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size() || !std::isfinite(value))
    bad(path, line, what + ": expected a finite number, got '" + text + "'");
  return value;
}

std::int64_t parse_count(const std::string& text, const std::string& path, int line,
                         const std::string& what) {
  const std::string t = trim(text);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size() || value < 1)
    bad(path, line, what + ": expected a whole number >= 1, got '" + text + "'");
  return value;
}

}  // namespace

IohExportOutcome export_iohprofiler(const std::string& campaign_dir, const std::string& out_dir) {
  const fs::path manifest_path = fs::path(campaign_dir) / "manifest.json";
  if (!fs::exists(manifest_path))
    throw std::runtime_error("--campaign " + campaign_dir +
                             ": no manifest.json (not a campaign "
                             "directory written by insid bench or insid sweep)");
  const nlohmann::json manifest = read_json_file(manifest_path);
  const CampaignConfig config = config_from_manifest(manifest, manifest_path.string());
  const int dimension = static_cast<int>(estimated_parameters(config).size());

  fs::create_directories(out_dir);  // the user's directory; what goes below it follows no link
  IohExportOutcome outcome;
  for (const AlgorithmSpec& algo : config.algorithms) {
    std::string alg_info = algo.name;
    const nlohmann::json resolved = config.to_json();
    for (const nlohmann::json& a : resolved["algorithms"]) {
      if (a["label"] != algo.label) continue;
      for (const auto& [key, value] : a["parameters"].items())
        alg_info += " " + key + "=" + value.dump();
    }
    for (std::size_t s = 0; s < config.scenarios.size(); ++s) {
      const ScenarioSpec& scenario = config.scenarios[s];
      const std::string fid = std::to_string(s + 1);
      const std::string instance = std::to_string(scenario.data_seed);
      const std::string dat_name = "data_f" + fid + "/IOHprofiler_f" + fid + "_DIM" +
                                   std::to_string(dimension) + "_i" + instance + ".dat";
      std::string dat, entries, seeds;
      for (const std::uint64_t seed : config.seeds) {
        const fs::path path = run_file(campaign_dir, scenario.name, algo.label, seed);
        const std::string problem = run_file_problem(path, scenario.name, algo.label, seed);
        if (problem == "missing") {
          ++outcome.missing_runs;
          continue;
        }
        const nlohmann::json record = read_run_record(path, scenario.name, algo.label, seed);
        const std::vector<double> trace =
            record["result"]["best_per_evaluation"].get<std::vector<double>>();
        dat += "\"function evaluation\" \"best-so-far f(x)\"\n";
        for (std::size_t e = 0; e < trace.size(); ++e) {
          if (e == 0 || trace[e] < trace[e - 1] || e + 1 == trace.size())
            dat += std::to_string(e + 1) + " " + number_text(trace[e], 17) + "\n";
        }
        entries += ", " + instance + ":" + std::to_string(trace.size()) + "|" +
                   number_text(trace.back(), 17);
        if (!seeds.empty()) seeds += ' ';
        seeds += std::to_string(seed);
        ++outcome.runs;
      }
      if (entries.empty()) continue;  // no run of this algorithm on this scenario yet
      const fs::path folder = fs::path(algo.label);  // under out_dir, links not followed
      WriteOptions write_options;
      write_options.create_directories = true;
      const std::string info =
          "suite = 'insid', funcId = " + fid + ", funcName = '" + header_safe(scenario.name) +
          "', DIM = " + std::to_string(dimension) + ", maximization = F, algId = '" +
          header_safe(algo.label) + "', algInfo = '" + header_safe(alg_info) + "'\n" +
          "% insid campaign " + header_safe(config.name) +
          ": f = Eq. 15 fitness (minimised) of the " +
          std::string(to_string(config.search_fitness)) +
          " search fitness; instance = the scenario's noise seed (data_seed); "
          "runs = optimizer seeds " +
          seeds + "\n" + dat_name + entries + "\n";
      write_file_atomic_under(out_dir, folder / ("IOHprofiler_f" + fid + "_i" + instance + ".info"),
                              info, write_options);
      write_file_atomic_under(out_dir, folder / dat_name, dat, write_options);
      ++outcome.info_files;
    }
  }
  return outcome;
}

std::string IohInfoBlock::value(const std::string& key) const {
  for (const auto& [k, v] : header) {
    if (k != key) continue;
    std::string text = v;
    if (text.size() >= 2 && (text.front() == '\'' || text.front() == '"') &&
        text.back() == text.front())
      text = text.substr(1, text.size() - 2);
    return text;
  }
  return "";
}

std::vector<IohInfoBlock> read_ioh_info(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  while (!lines.empty() && trim(lines.back()).empty()) lines.pop_back();
  if (lines.empty() || lines.size() % 3 != 0)
    bad(path, static_cast<int>(lines.size()),
        "expected blocks of three lines (header, % comment, data file and runs), got " +
            std::to_string(lines.size()) + " lines");
  std::vector<IohInfoBlock> blocks;
  for (std::size_t b = 0; b < lines.size(); b += 3) {
    IohInfoBlock block;
    const int n = static_cast<int>(b) + 1;
    // Line 1: name = value pairs separated by commas.
    for (const std::string& pair : split(lines[b], ',')) {
      const auto eq = pair.find('=');
      if (eq == std::string::npos) bad(path, n, "expected name = value, got '" + pair + "'");
      block.header.emplace_back(trim(pair.substr(0, eq)), trim(pair.substr(eq + 1)));
    }
    for (const char* mandatory : {"funcId", "DIM", "algId"}) {
      bool found = false;
      for (const auto& [k, v] : block.header) found = found || k == mandatory;
      if (!found) bad(path, n, std::string("mandatory key ") + mandatory + " missing");
    }
    // Line 2: a single '%' and the comment.
    if (lines[b + 1].empty() || lines[b + 1][0] != '%')
      bad(path, n + 1, "expected a line starting with '%', got '" + lines[b + 1] + "'");
    block.comment = trim(lines[b + 1].substr(1));
    // Line 3: data file, then instance:evaluations|best per run.
    const std::vector<std::string> record = split(lines[b + 2], ',');
    block.data_file = trim(record[0]);
    if (block.data_file.empty()) bad(path, n + 2, "no data file");
    if (record.size() < 2) bad(path, n + 2, "no run after the data file");
    for (std::size_t r = 1; r < record.size(); ++r) {
      const std::string entry = trim(record[r]);
      const auto colon = entry.find(':');
      const auto bar = entry.find('|');
      if (colon == std::string::npos || bar == std::string::npos || bar < colon)
        bad(path, n + 2,
            "run " + std::to_string(r) + ": expected instance:evaluations|best, got '" + entry +
                "'");
      IohInfoRun run;
      run.instance = entry.substr(0, colon);
      run.evaluations = parse_count(entry.substr(colon + 1, bar - colon - 1), path, n + 2,
                                    "run " + std::to_string(r) + " evaluations");
      run.best =
          parse_double(entry.substr(bar + 1), path, n + 2, "run " + std::to_string(r) + " best");
      block.runs.push_back(run);
    }
    blocks.push_back(std::move(block));
  }
  return blocks;
}

std::vector<IohDatRun> read_ioh_dat(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<IohDatRun> runs;
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty()) continue;
    if (line[0] == '"') {
      // A separation line: a new run; its first column must be "function evaluation" and it
      // must name the best-so-far column.
      if (line.rfind("\"function evaluation\"", 0) != 0)
        bad(path, n, "separation line must start with \"function evaluation\", got '" + line + "'");
      if (line.find("\"best-so-far f(x)\"") == std::string::npos)
        bad(path, n, "separation line has no \"best-so-far f(x)\" column");
      runs.emplace_back();
      continue;
    }
    if (runs.empty()) bad(path, n, "a record before the first separation line");
    const std::vector<std::string> columns = split(line, ' ');
    if (columns.size() != 2)
      bad(path, n, "expected 2 columns separated by one space, got '" + line + "'");
    const std::int64_t evaluation = parse_count(columns[0], path, n, "function evaluation");
    const double best = parse_double(columns[1], path, n, "best-so-far f(x)");
    if (!runs.back().empty()) {
      if (evaluation <= runs.back().back().first)
        bad(path, n,
            "function evaluation " + std::to_string(evaluation) + " after " +
                std::to_string(runs.back().back().first) + ": must increase");
      if (best > runs.back().back().second)
        bad(path, n,
            "best-so-far " + columns[1] + " larger than the previous record's (minimised)");
    }
    runs.back().emplace_back(evaluation, best);
  }
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (runs[r].empty()) bad(path, n, "run " + std::to_string(r + 1) + " has no record");
  return runs;
}

std::vector<double> expand_best_so_far(const IohDatRun& run) {
  std::vector<double> curve;
  if (run.empty()) return curve;
  // Before the first record nothing was evaluated yet (the export always records evaluation 1).
  curve.assign(static_cast<std::size_t>(run[0].first - 1),
               std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < run.size(); ++k) {
    const std::int64_t until = k + 1 < run.size() ? run[k + 1].first - 1 : run[k].first;
    while (static_cast<std::int64_t>(curve.size()) < until) curve.push_back(run[k].second);
  }
  return curve;
}

}  // namespace insid::campaign
