#!/usr/bin/env python3
"""Recompute a campaign's summary.json from its run files, independently of the C++ code.

Runs a small campaign (two scenarios, the paper's four algorithms, 8 seeds) with the given
`insid` binary, then recomputes every statistic of summary.json from the run files following
results/README.md's definitions, with numpy and scipy (not with insid's own statistics):
quartiles (numpy type 7), error blocks, success rates and COCO's aRT, convergence curves,
two-sided Mann-Whitney U (scipy.stats.mannwhitneyu), Holm's adjustment, Vargha-Delaney A12 and its
magnitude, the ranking and the Friedman test (scipy.stats.friedmanchisquare).

Usage: test_summary_recompute.py INSID_BINARY [WORK_DIR]
Exit 0 when every number agrees (relative 1e-9; counts and strings exactly), 1 otherwise.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
from scipy import stats

RTOL = 1e-9

CONFIG = {
    "name": "summary-recompute",
    "scenarios": [
        {"name": "rich-short", "preset": "rich", "flight_s": 600, "data_seed": 1},
        {"name": "racetrack-short", "preset": "racetrack", "flight_s": 600, "data_seed": 2},
    ],
    "algorithms": [
        {"name": "ga", "label": "GA"},
        {"name": "pso", "label": "PSO"},
        {"name": "pio", "label": "PIO"},
        {"name": "dvpio", "label": "DVPIO"},
    ],
    "seeds": 8,
    "max_iterations": 10,
}

failures = []


def close(a, b):
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, float) and math.isinf(a) or isinstance(b, float) and math.isinf(b):
        return a == b
    return abs(a - b) <= RTOL * max(abs(a), abs(b)) + 1e-300


def check(where, got, want):
    """got: summary.json's value; want: recomputed here."""
    if isinstance(want, (list, tuple, np.ndarray)):
        if len(got) != len(want):
            failures.append(f"{where}: {len(got)} values in summary.json, {len(want)} recomputed")
            return
        for i, (g, w) in enumerate(zip(got, want)):
            check(f"{where}[{i}]", g, w)
        return
    if isinstance(want, str) or isinstance(want, bool) or want is None:
        if got != want:
            failures.append(f"{where}: summary.json {got!r}, recomputed {want!r}")
        return
    if not close(float(got) if got is not None else None, float(want)):
        failures.append(f"{where}: summary.json {got!r}, recomputed {float(want)!r}")


def quartiles(v):
    v = np.asarray(v, dtype=float)
    return {"median": np.quantile(v, 0.5), "q1": np.quantile(v, 0.25), "q3": np.quantile(v, 0.75)}


def holm(p):
    p = np.asarray(p, dtype=float)
    m = len(p)
    order = np.argsort(p, kind="stable")
    adjusted = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, (m - rank) * p[i])
        adjusted[i] = min(1.0, running)
    return adjusted


def a12(a, b):
    greater = sum(1.0 for x in a for y in b if x > y)
    ties = sum(1.0 for x in a for y in b if x == y)
    return (greater + 0.5 * ties) / (len(a) * len(b))


def a12_magnitude(v):
    d = abs(v - 0.5)
    return "negligible" if d < 0.06 else "small" if d < 0.14 else "medium" if d < 0.21 else "large"


def recompute(out, summary):
    manifest = json.load(open(os.path.join(out, "manifest.json")))
    cfg = manifest["config"]
    friedman_rows = []
    for sc in cfg["scenarios"]:
        s = summary["scenarios"][sc["name"]]
        labels, finals_by = [], []
        for al in cfg["algorithms"]:
            label = al["label"]
            where = f"{sc['name']}/{label}"
            got = s["algorithms"][label]
            runs = [json.load(open(os.path.join(out, "runs", sc["name"], label, f"seed_{k}.json")))
                    for k in cfg["seeds"]]
            check(f"{where}.runs", got["runs"], len(runs))
            finals = [r["result"]["fitness"] for r in runs]
            for key, vals in (("final_fitness", finals),
                              ("evaluations", [r["result"]["evaluations"] for r in runs])):
                for q, v in quartiles(vals).items():
                    check(f"{where}.{key}.{q}", got[key][q], v)
            for block in ("error_sigma", "error_vs_optimum_sigma"):
                for name in runs[0][block]:
                    v = np.array([r[block][name] for r in runs])
                    want = quartiles(v)
                    want["median_abs"] = np.median(np.abs(v))
                    want["max_abs"] = np.max(np.abs(v))
                    for q, w in want.items():
                        check(f"{where}.{block}.{name}.{q}", got[block][name][q], w)
            success = []
            for tau in cfg["target_error_sigma"]:
                ok = sum(max(abs(x) for x in r["error_vs_optimum_sigma"].values()) <= tau for r in runs)
                success.append(("max_abs_error_vs_optimum_sigma", tau, ok / len(runs), None))
            for tau in cfg["target_fitness_gap"]:
                spent, hits = 0, 0
                for r in runs:
                    trace = np.array(r["result"]["best_per_evaluation"])
                    reached = np.nonzero(trace - r["optimum_fitness"] <= tau * abs(r["optimum_fitness"]))[0]
                    if len(reached):
                        hits += 1
                        spent += reached[0] + 1
                    else:
                        spent += len(trace)
                success.append(("relative_fitness_gap", tau, hits / len(runs),
                                spent / hits if hits else None))
            check(f"{where}.success.count", len(got["success"]), len(success))
            for i, (kind, tau, rate, ert) in enumerate(success):
                g = got["success"][i]
                check(f"{where}.success[{i}].kind", g["target"]["kind"], kind)
                check(f"{where}.success[{i}].value", g["target"]["value"], tau)
                check(f"{where}.success[{i}].rate", g["rate"], rate)
                check(f"{where}.success[{i}].ert", g["ert_evaluations"], ert)
            # Best-so-far curves, each run held at its last value beyond its end.
            max_it = max(len(r["result"]["history"]) for r in runs)
            check(f"{where}.curve_iterations.x", got["curve_iterations"]["x"], np.arange(1, max_it + 1))
            it_y = np.array([[r["result"]["history"][min(i, len(r["result"]["history"]) - 1)]["best_fitness"]
                              for i in range(max_it)] for r in runs])
            ev_x = np.array(got["curve_evaluations"]["x"], dtype=int)
            max_ev = max(len(r["result"]["best_per_evaluation"]) for r in runs)
            check(f"{where}.curve_evaluations.x[-1]", ev_x[-1], max_ev)
            ev_y = np.array([[r["result"]["best_per_evaluation"][min(e - 1, len(r["result"]["best_per_evaluation"]) - 1)]
                              for e in ev_x] for r in runs])
            for name, y in (("curve_iterations", it_y), ("curve_evaluations", ev_y)):
                for q, p in (("median", 0.5), ("q1", 0.25), ("q3", 0.75)):
                    check(f"{where}.{name}.{q}", got[name][q], np.quantile(y, p, axis=0))
            labels.append(label)
            finals_by.append(finals)
        # Pairwise tests, Holm over the scenario's pairs.
        pairs, ps = [], []
        for i in range(len(labels)):
            for j in range(i + 1, len(labels)):
                res = stats.mannwhitneyu(finals_by[i], finals_by[j], alternative="two-sided",
                                         use_continuity=True, method="auto")
                pairs.append((labels[i], labels[j], res.statistic, res.pvalue))
                ps.append(res.pvalue)
        adjusted = holm(ps)
        check(f"{sc['name']}.pairwise.count", len(s["pairwise"]), len(pairs))
        for k, ((a, b, u, p), ph) in enumerate(zip(pairs, adjusted)):
            g = s["pairwise"][k]
            w = f"{sc['name']}.pairwise[{a} vs {b}]"
            check(w + ".a", g["a"], a)
            check(w + ".b", g["b"], b)
            check(w + ".U", g["U"], u)
            check(w + ".p", g["p"], p)
            check(w + ".p_holm", g["p_holm"], ph)
            e = a12(finals_by[labels.index(a)], finals_by[labels.index(b)])
            check(w + ".a12", g["a12"], e)
            check(w + ".a12 == U / (n_a n_b)", g["a12"], u / (len(finals_by[0]) ** 2))
            check(w + ".a12_magnitude", g["a12_magnitude"], a12_magnitude(e))
        medians = [float(np.median(f)) for f in finals_by]
        check(f"{sc['name']}.ranking", s["ranking"], [labels[i] for i in np.argsort(medians, kind="stable")])
        friedman_rows.append(medians)
    if len(cfg["scenarios"]) >= 2:
        table = np.array(friedman_rows)  # rows = scenarios (blocks), columns = algorithms
        res = stats.friedmanchisquare(*table.T)
        check("friedman.statistic", summary["friedman"]["statistic"], res.statistic)
        check("friedman.p", summary["friedman"]["p"], res.pvalue)
        ranks = np.mean([stats.rankdata(row) for row in table], axis=0)
        for al, r in zip(cfg["algorithms"], ranks):
            check(f"friedman.ranks.{al['label']}", summary["friedman"]["ranks"][al["label"]], r)
    elif "friedman" in summary:
        failures.append("friedman present with a single scenario")


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    insid = sys.argv[1]
    work = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp(prefix="insid-summary-")
    os.makedirs(work, exist_ok=True)
    out = os.path.join(work, "campaign")
    shutil.rmtree(out, ignore_errors=True)
    cfg_path = os.path.join(work, "config.json")
    with open(cfg_path, "w") as f:
        json.dump(CONFIG, f)
    subprocess.run([insid, "bench", "--config", cfg_path, "--out", out, "--threads", "2"],
                   check=True, stderr=subprocess.DEVNULL)
    summary = json.load(open(os.path.join(out, "summary.json")))
    recompute(out, summary)
    checked = "every descriptive, success rate, aRT, curve, U, p, Holm p, A12, ranking and Friedman figure"
    if failures:
        print(f"summary.json disagrees with the recomputation in {len(failures)} places:")
        for line in failures[:40]:
            print("  " + line)
        return 1
    print(f"summary.json recomputed from {out}/runs: {checked} agrees (rtol {RTOL})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
