#!/usr/bin/env python3
"""Accuracy tables (algorithm x scenario) from campaign directories (results/accuracy/README.md).

Usage: accuracy_table.py ROOT  -- ROOT holds one campaign directory per config in
ROOT/configs/*.json (named like the config without .json). Prints markdown to stdout.

Two questions, reported separately (docs/design.md sec. 10):
  * how well does the optimizer solve the problem: |estimate - data's own optimum| (sigma)
    and the relative fitness gap (f - f_opt) / f_opt;
  * how well can the biases be known from these data: |estimate - truth| (sigma), next to the
    noise floor = spread of the data's optimum around the truth over noise seeds.
"""
import glob
import json
import lzma
import math
import os
import re
import statistics
import sys


def load(path):
    # Packed results (scripts/pack_results.py): PATH.xz where PATH is absent.
    if not os.path.exists(path) and os.path.exists(path + ".xz"):
        path += ".xz"
    with (lzma.open(path, "rt") if path.endswith(".xz") else open(path)) as f:
        return json.load(f)


def fmt(v):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    a = abs(v)
    if a != 0 and (a < 1e-3 or a >= 1e4):
        return f"{v:.2e}"
    return f"{v:.3g}"


def campaign_rows(cdir):
    manifest = load(os.path.join(cdir, "manifest.json"))
    cfg = manifest["config"]
    params = [p["name"] for p in cfg["estimate"]]
    rows = []
    for sc in cfg["scenarios"]:
        for alg in cfg["algorithms"]:
            runs = []
            for seed in cfg["seeds"]:
                p = os.path.join(cdir, "runs", sc["name"], alg["label"], f"seed_{seed}.json")
                if os.path.exists(p) or os.path.exists(p + ".xz"):
                    runs.append(load(p))
            if not runs:
                continue
            r = {"scenario": sc["name"], "alignment": cfg["alignment"], "algorithm": alg["label"],
                 "runs": len(runs), "params": params}
            for key in ("error_vs_optimum_sigma", "error_sigma"):
                if key in runs[0]:
                    r[key] = {p: ([abs(x[key][p]) for x in runs]) for p in params}
            r["fitness"] = [x["result"]["fitness"] for x in runs]
            r["gap_rel"] = [x.get("fitness_gap_relative", float("nan")) for x in runs]
            r["evals"] = [x["result"]["evaluations"] for x in runs]
            r["optimum_fitness"] = runs[0].get("optimum_fitness")
            rows.append(r)
    return rows


def noise_floor(cdir):
    """Data's optimum minus truth over noise seeds, per parameter, sigma units: mean (a bias
    common to all seeds), sample SD (the spread noise causes) and RMS."""
    manifest = load(os.path.join(cdir, "manifest.json"))
    cfg = manifest["config"]
    params = [p["name"] for p in cfg["estimate"]]
    diffs = {p: [] for p in params}
    for sc in cfg["scenarios"]:
        opt = load(os.path.join(cdir, "optimum", sc["name"] + ".json"))
        run = load(os.path.join(cdir, "runs", sc["name"], cfg["algorithms"][0]["label"], "seed_1.json"))
        for p in params:
            # insid-run/1 records name it "estimate_sigma"
            est = opt.get("estimate_in_sigma_units") or opt["estimate_sigma"]
            diffs[p].append(est[p] - run["truth_sigma"][p])
    stats = {}
    for p, v in diffs.items():
        stats[p] = {"mean": statistics.fmean(v),
                    "sd": statistics.stdev(v) if len(v) > 1 else float("nan"),
                    "rms": math.sqrt(sum(d * d for d in v) / len(v)),
                    "max_abs": max(abs(d) for d in v)}
    return stats, len(cfg["scenarios"]), cfg["alignment"]


LADDER = re.compile(r"^ladder-(?P<scenario>.+)-E(?P<budget>[0-9]+)$")


def short_names(params):
    return [p.replace("accel_bias_", "A").replace("gyro_bias_", "D") for p in params]


def error_vs_optimum_cells(algo, params):
    """'median / worst' |error vs optimum| per parameter from one algorithm's summary."""
    errors = algo["error_vs_optimum_sigma"]
    return [f"{fmt(errors[p]['median_abs'])} / {fmt(errors[p]['max_abs'])}" for p in params]


def runs_within_cell(algo, target_sigma):
    """'k / n' runs with every parameter within target_sigma of the optimum, or '–'."""
    for t in algo["success"]:
        if t["target"]["kind"] == "max_abs_error_vs_optimum_sigma" and t["target"]["value"] == target_sigma:
            return f"{round(t['rate'] * algo['runs'])} / {algo['runs']}"
    return "–"


def ladder_rows(root):
    """Budget ladder (configs/ladder-<scenario>-E<evaluations>.json) plus, as its first rung,
    the Table 4 campaign <scenario>-per-candidate (40 iterations): from the summaries only.
    Rows: (scenario, algorithm label, its summary, (p, A12) of DVPIO vs PIO on DVPIO's row)."""
    rungs = []
    for cfgpath in glob.glob(os.path.join(root, "configs", "ladder-*.json")):
        m = LADDER.match(os.path.basename(cfgpath)[:-5])
        if m:
            rungs.append((m["scenario"], os.path.join(root, os.path.basename(cfgpath)[:-5])))
    for scenario in sorted({sc for sc, _ in rungs}):
        rungs.append((scenario, os.path.join(root, scenario + "-per-candidate")))
    rows = []
    for scenario, cdir in rungs:
        path = os.path.join(cdir, "summary.json")
        if not os.path.exists(path):
            continue
        summary_scenario = load(path)["scenarios"][scenario]
        # Two-sided Mann-Whitney on the final fitness, DVPIO against PIO at the same budget.
        vs_pio = None
        for pair in summary_scenario.get("pairwise", []):
            if {pair["a"], pair["b"]} == {"DVPIO", "PIO"}:
                a12_pio_higher = pair["a12"] if pair["a"] == "PIO" else 1.0 - pair["a12"]
                vs_pio = (pair["p"], a12_pio_higher)
        for label, algo in summary_scenario["algorithms"].items():
            rows.append((scenario, label, algo, vs_pio if label == "DVPIO" else None))
    rows.sort(key=lambda r: (r[0], r[1], r[2]["evaluations"]["median"]))
    return rows


def ladder_table(root):
    rows = ladder_rows(root)
    if not rows:
        return []
    params = list(rows[0][2]["error_vs_optimum_sigma"].keys())
    out = ["\n### Budget ladder, alignment `per-candidate`: |error vs the data's optimum| (σ), "
           "median / worst over seeds\n",
           "| scenario | algorithm | evaluations | " + " | ".join(short_names(params)) +
           " | runs with every parameter ≤ 0.1 σ | final fitness (median) | DVPIO vs PIO: p, A12 |",
           "|" + "---|" * (3 + len(params) + 3)]
    for scenario, label, algo, vs_pio in rows:
        cells = [f"`{scenario}`", label, f"{algo['evaluations']['median']:.0f}"]
        cells += error_vs_optimum_cells(algo, params)
        cells.append(runs_within_cell(algo, 0.1))
        cells.append(fmt(algo["final_fitness"]["median"]))
        cells.append("–" if vs_pio is None else f"{fmt(vs_pio[0])}, {fmt(vs_pio[1])}")
        out.append("| " + " | ".join(cells) + " |")
    out.append("\nLast column: two-sided Mann-Whitney p on the final fitness (no correction: one "
               "pair per budget) and A12 = P(PIO ends higher than DVPIO).")
    return out


def variant_table(root):
    """configs/variant-*.json: DVPIO against an insid variant of it, from the summaries."""
    out = []
    for cfgpath in sorted(glob.glob(os.path.join(root, "configs", "variant-*.json"))):
        cdir = os.path.join(root, os.path.basename(cfgpath)[:-5])
        path = os.path.join(cdir, "summary.json")
        if not os.path.exists(path):
            continue
        summary = load(path)
        cfg = load(os.path.join(cdir, "manifest.json"))["config"]
        budget = (f"{cfg['max_evaluations']} evaluations" if cfg["max_evaluations"]
                  else f"{cfg['max_iterations']} iterations")
        for scenario, sc in summary["scenarios"].items():
            labels = list(sc["algorithms"].keys())
            params = list(sc["algorithms"][labels[0]]["error_vs_optimum_sigma"].keys())
            out.append(f"\n### Variant `{os.path.basename(cdir)}`: `{scenario}`, {budget}, "
                       f"{sc['algorithms'][labels[0]]['runs']} seeds; |error vs the data's optimum| "
                       "(σ), median / worst\n")
            out.append("| algorithm | " + " | ".join(short_names(params)) +
                       " | runs with every parameter ≤ 0.1 σ | final fitness median [q1, q3] |")
            out.append("|" + "---|" * (len(params) + 3))
            for label in labels:
                algo = sc["algorithms"][label]
                ff = algo["final_fitness"]
                cells = [label] + error_vs_optimum_cells(algo, params)
                cells.append(runs_within_cell(algo, 0.1))
                cells.append(f"{fmt(ff['median'])} [{fmt(ff['q1'])}, {fmt(ff['q3'])}]")
                out.append("| " + " | ".join(cells) + " |")
            for pair in sc.get("pairwise", []):
                out.append(f"\nTwo-sided Mann-Whitney on the final fitness, {pair['a']} vs "
                           f"{pair['b']}: p = {fmt(pair['p'])}, A12 = P({pair['a']} ends higher) = "
                           f"{fmt(pair['a12'])}.")
    return out


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "results/accuracy"
    out = []
    floors = {}
    for cfgpath in sorted(glob.glob(os.path.join(root, "configs", "noise-floor-*.json"))):
        cdir = os.path.join(root, os.path.basename(cfgpath)[:-5])
        if os.path.exists(os.path.join(cdir, "manifest.json")):
            try:
                fl, n, al = noise_floor(cdir)
                floors[al] = (fl, n)
            except (OSError, KeyError):
                pass
    for al, (fl, n) in sorted(floors.items()):
        out.append(f"\n### Noise floor (`rich`, `nav` grade, alignment `{al}`): data's optimum − truth "
                   f"over {n} noise seeds (σ)\n")
        out.append("| parameter | mean | SD | RMS | max \\|·\\| |")
        out.append("|---|---|---|---|---|")
        for p, st in fl.items():
            out.append(f"| {p} | {fmt(st['mean'])} | {fmt(st['sd'])} | {fmt(st['rms'])} | {fmt(st['max_abs'])} |")
    out += ladder_table(root)
    out += variant_table(root)
    for cfgpath in sorted(glob.glob(os.path.join(root, "configs", "*.json"))):
        name = os.path.basename(cfgpath)[:-5]
        if name.startswith(("noise-floor", "ladder-", "variant-")):
            continue
        cdir = os.path.join(root, name)
        if not os.path.exists(os.path.join(cdir, "manifest.json")):
            continue
        rows = campaign_rows(cdir)
        if not rows:
            continue
        params = rows[0]["params"]
        short = short_names(params)
        out.append(f"\n### `{rows[0]['scenario']}`, alignment `{rows[0]['alignment']}` "
                   f"({rows[0]['runs']} seeds; data's optimum Eq. 15 = {fmt(rows[0]['optimum_fitness'])})\n")
        head = ("| algorithm | " + " | ".join(f"{s} vs opt med / worst" for s in short) + " | " +
                " | ".join(f"{s} vs truth med / worst" for s in short) +
                " | final fitness (median) | gap to optimum (median, relative) | evaluations |")
        out.append(head)
        out.append("|" + "---|" * (2 + 2 * len(params) + 2 + 1 - 1))
        for r in rows:
            cells = [r["algorithm"]]
            for key in ("error_vs_optimum_sigma", "error_sigma"):
                for p in params:
                    v = r.get(key, {}).get(p)
                    cells.append(f"{fmt(statistics.median(v))} / {fmt(max(v))}" if v else "–")
            cells.append(fmt(statistics.median(r["fitness"])))
            cells.append(fmt(statistics.median(r["gap_rel"])))
            cells.append(fmt(statistics.median(r["evals"])))
            out.append("| " + " | ".join(cells) + " |")
    print("\n".join(out))


if __name__ == "__main__":
    main()
