// summary.json of a campaign: descriptives, success rates and aRT, convergence curves, pairwise
// Mann-Whitney tests with Holm correction and Vargha-Delaney A12, Friedman across scenarios.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "bench/campaign.h"
#include "bench/stats.h"

namespace insid::campaign {
namespace {

nlohmann::json quartiles_json(const std::vector<double>& v) {
  const stats::Quartiles q = stats::quartiles(v);
  return {{"median", q.median}, {"q1", q.q1}, {"q3", q.q3}};
}

nlohmann::json curve_json(const std::vector<double>& x,
                          const std::vector<std::vector<double>>& ys) {
  // ys[run][i] at x[i]
  nlohmann::json c;
  c["x"] = x;
  std::vector<double> med, q1, q3;
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::vector<double> col;
    for (const auto& y : ys) col.push_back(y[i]);
    const stats::Quartiles q = stats::quartiles(col);
    med.push_back(q.median);
    q1.push_back(q.q1);
    q3.push_back(q.q3);
  }
  c["median"] = med;
  c["q1"] = q1;
  c["q3"] = q3;
  return c;
}

// Evaluation grid for curves: every evaluation up to 400, then ~400 log-spaced points.
std::vector<double> evaluation_grid(std::int64_t max_evals) {
  std::vector<double> grid;
  if (max_evals <= 400) {
    for (std::int64_t e = 1; e <= max_evals; ++e) grid.push_back(static_cast<double>(e));
    return grid;
  }
  const double ratio = std::pow(static_cast<double>(max_evals), 1.0 / 399.0);
  double v = 1.0;
  std::int64_t last = 0;
  for (int i = 0; i < 400; ++i, v *= ratio) {
    const auto e = std::min<std::int64_t>(max_evals, std::llround(v));
    if (e > last) grid.push_back(static_cast<double>(e));
    last = e;
  }
  if (grid.back() != static_cast<double>(max_evals)) grid.push_back(static_cast<double>(max_evals));
  return grid;
}

}  // namespace

nlohmann::json summarize_campaign(const std::string& out_dir, const CampaignConfig& config) {
  nlohmann::json summary;
  summary["schema"] = "insid-summary/1";
  summary["campaign"] = config.name;
  std::vector<std::vector<double>> friedman_table;
  for (const ScenarioSpec& scenario : config.scenarios) {
    nlohmann::json sj;
    std::vector<std::vector<double>> finals_by_algo;
    std::vector<std::string> labels;
    friedman_table.emplace_back();
    for (const AlgorithmSpec& algo : config.algorithms) {
      std::vector<nlohmann::json> runs;
      for (std::uint64_t seed : config.seeds) {
        const std::string path = run_file(out_dir, scenario.name, algo.label, seed);
        runs.push_back(read_run_record(path, scenario.name, algo.label, seed));
      }
      nlohmann::json aj;
      aj["runs"] = runs.size();
      std::vector<double> finals, walls;
      for (const auto& r : runs) {
        finals.push_back(r["result"]["fitness"].get<double>());
        walls.push_back(r["result"]["wall_s"].get<double>());
      }
      aj["final_fitness"] = quartiles_json(finals);
      aj["wall_s"] = {{"median", stats::median(walls)},
                      {"total", std::accumulate(walls.begin(), walls.end(), 0.0)}};
      aj["evaluations"] = quartiles_json([&] {
        std::vector<double> e;
        for (const auto& r : runs) e.push_back(r["result"]["evaluations"].get<double>());
        return e;
      }());
      for (const char* block : {"error_sigma", "error_vs_optimum_sigma"}) {
        if (!runs.front().contains(block)) continue;
        for (const auto& item : runs.front()[block].items()) {
          std::vector<double> v, a;
          for (const auto& r : runs) {
            v.push_back(r[block][item.key()].get<double>());
            a.push_back(std::abs(v.back()));
          }
          nlohmann::json q = quartiles_json(v);
          q["median_abs"] = stats::median(a);
          q["max_abs"] = *std::max_element(a.begin(), a.end());
          aj[block][item.key()] = q;
        }
      }
      // Success rates and aRT.
      nlohmann::json success = nlohmann::json::array();
      for (double tau : config.target_error_sigma) {
        std::size_t ok = 0;
        for (const auto& r : runs) {
          double worst = 0.0;
          for (const auto& item : r["error_vs_optimum_sigma"].items())
            worst = std::max(worst, std::abs(item.value().get<double>()));
          ok += worst <= tau ? 1 : 0;
        }
        success.push_back({{"target", {{"kind", "max_abs_error_vs_optimum_sigma"}, {"value", tau}}},
                           {"rate", static_cast<double>(ok) / static_cast<double>(runs.size())},
                           {"ert_evaluations", nullptr}});
      }
      for (double tau : config.target_fitness_gap) {
        std::vector<stats::RunOutcome> outcomes;
        for (const auto& r : runs) {
          const double f_opt = r["optimum_fitness"].get<double>();
          const auto& trace = r["result"]["best_per_evaluation"];
          stats::RunOutcome o;
          o.evaluations = static_cast<double>(trace.size());
          for (std::size_t i = 0; i < trace.size(); ++i)
            if ((trace[i].get<double>() - f_opt) <= tau * std::abs(f_opt)) {
              o.evaluations = static_cast<double>(i + 1);
              o.reached = true;
              break;
            }
          outcomes.push_back(o);
        }
        const stats::RunningTime rt = stats::expected_running_time(outcomes);
        nlohmann::json ert =
            std::isfinite(rt.art) ? nlohmann::json(rt.art) : nlohmann::json(nullptr);
        success.push_back({{"target", {{"kind", "relative_fitness_gap"}, {"value", tau}}},
                           {"rate", rt.success_rate},
                           {"ert_evaluations", ert}});
      }
      aj["success"] = success;
      // Convergence curves (best-so-far) over iterations and over evaluations.
      std::int64_t max_it = 0, max_ev = 0;
      for (const auto& r : runs) {
        max_it = std::max<std::int64_t>(max_it, r["result"]["history"].size());
        max_ev = std::max<std::int64_t>(max_ev, r["result"]["best_per_evaluation"].size());
      }
      std::vector<double> it_x;
      for (std::int64_t i = 1; i <= max_it; ++i) it_x.push_back(static_cast<double>(i));
      std::vector<std::vector<double>> it_y, ev_y;
      const std::vector<double> ev_x = evaluation_grid(max_ev);
      for (const auto& r : runs) {
        const auto& h = r["result"]["history"];
        std::vector<double> y;
        for (std::int64_t i = 0; i < max_it; ++i)
          y.push_back(
              h[std::min<std::size_t>(static_cast<std::size_t>(i), h.size() - 1)]["best_fitness"]
                  .get<double>());
        it_y.push_back(y);
        const auto& t = r["result"]["best_per_evaluation"];
        std::vector<double> ye;
        for (double e : ev_x)
          ye.push_back(t[std::min<std::size_t>(static_cast<std::size_t>(e) - 1, t.size() - 1)]
                           .get<double>());
        ev_y.push_back(ye);
      }
      aj["curve_iterations"] = curve_json(it_x, it_y);
      aj["curve_evaluations"] = curve_json(ev_x, ev_y);
      sj["algorithms"][algo.label] = aj;
      finals_by_algo.push_back(finals);
      labels.push_back(algo.label);
      friedman_table.back().push_back(stats::median(finals));
    }
    // Pairwise two-sided Mann-Whitney on final fitness, Holm over the scenario's pairs. Sweeps
    // (more than kMaxPairwise settings) skip it: their per-setting CIs are in sweep.json.
    constexpr std::size_t kMaxPairwise = 12;
    nlohmann::json pairwise = nlohmann::json::array();
    std::vector<double> ps;
    for (std::size_t a = 0; a < labels.size() && labels.size() <= kMaxPairwise; ++a)
      for (std::size_t b = a + 1; b < labels.size(); ++b) {
        const stats::MannWhitneyResult mw =
            stats::mann_whitney_u(finals_by_algo[a], finals_by_algo[b]);
        const double a12 = stats::a12(finals_by_algo[a], finals_by_algo[b]);
        pairwise.push_back(
            {{"a", labels[a]},
             {"b", labels[b]},
             {"metric", "final_fitness"},
             {"U", mw.u},
             {"p", mw.p},
             {"a12", a12},
             {"a12_magnitude", std::string(stats::to_string(stats::a12_magnitude(a12)))},
             {"method", std::string(stats::to_string(mw.method))}});
        ps.push_back(mw.p);
      }
    const std::vector<double> adjusted = stats::holm(ps);
    for (std::size_t i = 0; i < adjusted.size(); ++i) pairwise[i]["p_holm"] = adjusted[i];
    sj["pairwise"] = pairwise;
    std::vector<std::size_t> order(labels.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      return friedman_table.back()[x] < friedman_table.back()[y];
    });
    for (std::size_t i : order) sj["ranking"].push_back(labels[i]);
    summary["scenarios"][scenario.name] = sj;
  }
  if (config.scenarios.size() >= 2 && config.algorithms.size() >= 2) {
    const stats::FriedmanResult fr = stats::friedman(friedman_table);
    nlohmann::json fj;
    fj["statistic"] =
        std::isfinite(fr.statistic) ? nlohmann::json(fr.statistic) : nlohmann::json(nullptr);
    fj["p"] = std::isfinite(fr.p) ? nlohmann::json(fr.p) : nlohmann::json(nullptr);
    for (std::size_t a = 0; a < config.algorithms.size(); ++a)
      fj["ranks"][config.algorithms[a].label] = fr.mean_ranks[a];
    fj["note"] = fr.note;
    summary["friedman"] = fj;
  }
  return summary;
}

}  // namespace insid::campaign
