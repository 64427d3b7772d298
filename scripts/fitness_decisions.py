#!/usr/bin/env python3
"""Do the fast and the exact search fitness lead the optimizers to the same answers? (issue 47,
criterion 2; results/perf/fast-fitness/decisions.md)

For each flight, one campaign per fitness (`insid bench --fitness fast|exact`, the same config,
seeds 1..S): GA, PSO, PIO, DVPIO and CMA-ES (stochastic: same seeds diverge after the first
differing comparison, so their distributions are compared), and in a second campaign with a
budget to converge in, Nelder-Mead and LM (deterministic from their seed's start: compared run by
run). Per stochastic algorithm and per reported quantity (the
final exact Eq. 15 and each estimate in sigma units): both medians with bootstrap 95 % intervals
(seeded percentile bootstrap), whether each median lies inside the other's interval, and a
two-sided Mann-Whitney U test, Holm-corrected over all tests of the flight. Nelder-Mead: the
largest |estimate_fast - estimate_exact| over the runs, in units of the estimate's sd (from
`insid identify --algo lm` on the same flight, 100 noise replicas), against 0.05.

Usage: fitness_decisions.py --insid build/cli/insid --out DIR [--seeds 31]
         [--flight rich:600] [--flight racetrack:600] [--evaluations 400]
Writes DIR/<flight>/{fast,exact}/ (campaigns), DIR/decisions.json and prints a markdown table.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
from scipy.stats import mannwhitneyu

STOCHASTIC = [("GA", "ga"), ("PSO", "pso"), ("PIO", "pio"), ("DVPIO", "dvpio"),
              ("CMA-ES", "cmaes")]
# Local searches, from the seed's start, with a budget to converge in (--local-evaluations). LM
# reads residual vectors, which come from the exact kernel under either fitness.
DETERMINISTIC = [("NM", "neldermead"), ("LM", "lm")]


def bootstrap_median_ci(x, rng, resamples=10000):
    x = np.asarray(x)
    idx = rng.integers(0, len(x), size=(resamples, len(x)))
    medians = np.median(x[idx], axis=1)
    return float(np.percentile(medians, 2.5)), float(np.percentile(medians, 97.5))


def holm(pvalues):
    order = sorted(range(len(pvalues)), key=lambda i: pvalues[i])
    adjusted = [0.0] * len(pvalues)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(pvalues) - rank) * pvalues[i]))
        adjusted[i] = running
    return adjusted


def run_campaigns(insid, out, preset, flight_s, seeds, evaluations, algorithms):
    config = {
        "name": f"decisions-{preset}",
        "scenarios": [{"name": preset, "preset": preset, "flight_s": flight_s, "grade": "nav",
                       "data_seed": 1}],
        "algorithms": [{"label": label, "name": name} for label, name in algorithms],
        "seeds": seeds,
        "max_iterations": 0,
        "max_evaluations": evaluations,
    }
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "config.json")
    with open(path, "w") as f:
        json.dump(config, f, indent=1)
    wall = {}
    for fitness in ("fast", "exact"):
        t0 = time.monotonic()
        subprocess.run([insid, "bench", "--config", path, "--fitness", fitness, "--out",
                        os.path.join(out, fitness), "-q"], check=True)
        wall[fitness] = time.monotonic() - t0
    return config, wall


def read_runs(directory, scenario, label, seeds):
    runs = []
    for seed in range(1, seeds + 1):
        with open(os.path.join(directory, "runs", scenario, label, f"seed_{seed}.json")) as f:
            runs.append(json.load(f))
    return runs


def lm_sd_sigma(insid, out, preset, flight_s):
    """The estimates' sd in sigma units, from an exact LM identify with 100 noise replicas."""
    data = os.path.join(out, "data")
    if not os.path.isdir(data):
        subprocess.run([insid, "simulate", "--preset", preset, "--flight-s", str(flight_s),
                        "--grade", "nav", "--seed", "1", "--out", data], check=True,
                       stderr=subprocess.DEVNULL)
    result = os.path.join(out, "lm.json")
    subprocess.run([insid, "identify", "--data", data, "--algo", "lm", "--fitness", "exact",
                    "--out", result, "-q"], check=True)
    with open(result) as f:
        j = json.load(f)
    sigma = {e["name"]: e["sigma"] for e in j["estimated"]}
    return {p["name"]: p["sd"] / sigma[p["name"]] for p in j["parameters"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--insid", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=31)
    ap.add_argument("--evaluations", type=int, default=400)
    ap.add_argument("--local-evaluations", type=int, default=4000,
                    help="the local searches' budget; 0 leaves them out (the paper flight: each "
                         "exact local run of 4000 evaluations takes minutes)")
    ap.add_argument("--local", default="NM,LM",
                    help="the local searches to run (LM keeps every candidate's residual vector: "
                         "31 LM runs on the 2.4 h paper flight need more than 13 GB)")
    ap.add_argument("--flight", action="append", default=None,
                    help="PRESET:FLIGHT_S (navigation grade, noise seed 1); repeatable")
    args = ap.parse_args()
    local_searches = [d for d in DETERMINISTIC if d[0] in args.local.split(",")]
    flights = args.flight or ["rich:600", "racetrack:600"]
    rng = np.random.default_rng(47)
    report = {"seeds": args.seeds, "evaluations": args.evaluations, "flights": []}
    ok = True
    print("| flight | algorithm | quantity | median fast [95 % CI] | median exact [95 % CI] | "
          "inside each other's CI | p | p_Holm |")
    print("|---|---|---|---|---|---|---|---|")
    for flight in flights:
        preset, flight_s = flight.split(":")
        out = os.path.join(args.out, preset)
        config, wall = run_campaigns(args.insid, out, preset, float(flight_s), args.seeds,
                                     args.evaluations, STOCHASTIC)
        local = os.path.join(out, "local")
        if args.local_evaluations > 0:
            run_campaigns(args.insid, local, preset, float(flight_s), args.seeds,
                          args.local_evaluations, local_searches)
        names = [p["name"] for p in json.load(
            open(os.path.join(out, "fast", "manifest.json")))["config"]["estimate"]]
        rows = []
        for label, _ in STOCHASTIC:
            fast = read_runs(os.path.join(out, "fast"), preset, label, args.seeds)
            exact = read_runs(os.path.join(out, "exact"), preset, label, args.seeds)
            quantities = {"final Eq. 15 (exact)": ([r["result"]["fitness"] for r in fast],
                                                   [r["result"]["fitness"] for r in exact])}
            for n in names:
                quantities[n] = ([r["estimate_in_sigma_units"][n] for r in fast],
                                 [r["estimate_in_sigma_units"][n] for r in exact])
            for q, (a, b) in quantities.items():
                ca, cb = bootstrap_median_ci(a, rng), bootstrap_median_ci(b, rng)
                ma, mb = float(np.median(a)), float(np.median(b))
                p = 1.0 if a == b else float(mannwhitneyu(a, b, alternative="two-sided").pvalue)
                rows.append({"algorithm": label, "quantity": q, "median_fast": ma, "ci_fast": ca,
                             "median_exact": mb, "ci_exact": cb,
                             "inside": ca[0] <= mb <= ca[1] and cb[0] <= ma <= cb[1],
                             "identical_runs": sum(x == y for x, y in zip(a, b)), "p": p})
        for row, p_holm in zip(rows, holm([r["p"] for r in rows])):
            row["p_holm"] = p_holm
            ok = ok and row["inside"] and p_holm >= 0.05
            print(f"| {preset} {flight_s} s | {row['algorithm']} | {row['quantity']} | "
                  f"{row['median_fast']:.6g} [{row['ci_fast'][0]:.6g}, {row['ci_fast'][1]:.6g}] | "
                  f"{row['median_exact']:.6g} [{row['ci_exact'][0]:.6g}, "
                  f"{row['ci_exact'][1]:.6g}] | {'yes' if row['inside'] else 'NO'} | "
                  f"{row['p']:.3g} | {row['p_holm']:.3g} |")
        deterministic = []
        sd = lm_sd_sigma(args.insid, out, preset, float(flight_s)) if args.local_evaluations else {}
        for label, _ in (local_searches if args.local_evaluations > 0 else []):
            fast = read_runs(os.path.join(local, "fast"), preset, label, args.seeds)
            exact = read_runs(os.path.join(local, "exact"), preset, label, args.seeds)
            worst = max(abs(f["estimate_in_sigma_units"][n] - e["estimate_in_sigma_units"][n]) /
                        sd[n] for f, e in zip(fast, exact) for n in names)
            unconverged = sum(r["result"]["termination"] != "target" and
                              r["result"]["evaluations"] >= args.local_evaluations
                              for r in fast + exact)
            deterministic.append({"algorithm": label, "max_abs_difference_in_sd": worst,
                                  "sd_sigma": sd, "runs_at_budget": unconverged})
            ok = ok and worst <= 0.05
            print(f"| {preset} {flight_s} s | {label} (same start) | max |fast - exact| / sd "
                  f"over {args.seeds} starts ({unconverged} runs at the budget) | {worst:.3g} | | "
                  f"{'yes' if worst <= 0.05 else 'NO'} (<= 0.05) | | |")
        report["flights"].append({"flight": flight, "wall_s": wall, "stochastic": rows,
                                  "deterministic": deterministic})
        print(f"\n{preset} {flight_s} s: campaign wall fast {wall['fast']:.1f} s, exact "
              f"{wall['exact']:.1f} s\n", file=sys.stderr)
    report["all_hold"] = ok
    with open(os.path.join(args.out, "decisions.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(f"\ncriterion 2 {'holds' if ok else 'does NOT hold'} on every flight")
    return 0


if __name__ == "__main__":
    sys.exit(main())
