#!/usr/bin/python3
"""Figures and a Markdown report from a campaign (or sweep) directory written by `insid bench`
(or `insid sweep`).

Usage: /usr/bin/python3 scripts/campaign_report.py DIR [--alpha 0.05] [--dpi 110]

Reads DIR/manifest.json, DIR/summary.json, DIR/runs/<scenario>/<algorithm>/seed_<k>.json and,
for a sweep, DIR/sweep.json; writes DIR/figures/*.png and DIR/report.md. Every input except the
run files is optional: what summary.json lacks (quartiles, curves, pairwise tests) is recomputed
from the run files with numpy/scipy. Uses Debian's python3-matplotlib / numpy / scipy.

Figures (per scenario):
  convergence_iterations_<s>.png   best-so-far fitness vs iteration, median + IQR band (Fig. 9)
  convergence_evaluations_<s>.png  the same vs fitness evaluations (equal-cost axis)
  final_fitness_<s>.png            box plots of the final fitness per algorithm
  parameter_errors_<s>.png         box plots of |error_sigma| per parameter per algorithm
  positions_<algo>_<s>_seed<k>.png particle positions per dimension (Figs. 10-13), PIO/DVPIO
  sweep_heatmap_<p>_<q>.png        median final fitness over each pair of swept parameters
"""
import argparse
import datetime
import itertools
import json
import lzma
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter  # noqa: E402

try:  # scipy is only needed when summary.json lacks the pairwise tests
    from scipy import stats as sps  # noqa: E402
except ImportError:  # pragma: no cover
    sps = None

POSITION_ALGORITHMS = ("pio", "dvpio")


# ------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------

def estimate_in_sigma_units(block):
    """The estimate in sigma units of a run / optimum block: "estimate_in_sigma_units"
    (insid-run/2, insid-identify/2) or, in older files, "estimate_sigma"."""
    return block.get("estimate_in_sigma_units") or block.get("estimate_sigma") or {}


def warn(msg):
    print(f"campaign_report: warning: {msg}", file=sys.stderr)


def without_curves(value):
    if isinstance(value, dict):
        return {k: without_curves(v) for k, v in value.items()
                if k not in ("curve_evaluations", "curve_iterations")}
    if isinstance(value, list):
        return [without_curves(v) for v in value]
    return value


def packed_full_summary(path):
    """NAME.full.json.xz beside NAME.json (scripts/pack_results.py), when NAME.json is that file
    less its curves; None otherwise (no companion, or NAME.json written again since: stale)."""
    full_path = path[:-len(".json")] + ".full.json.xz" if path.endswith(".json") else None
    if not full_path or not os.path.exists(full_path) or not os.path.exists(path):
        return None
    try:
        with lzma.open(full_path, "rt") as f:
            full = json.load(f)
        with open(path) as f:
            plain = json.load(f)
    except (OSError, ValueError, lzma.LZMAError) as e:
        warn(f"skipping {full_path}: {e}")
        return None
    if without_curves(full) != plain:
        warn(f"{full_path} is not {path} with its curves (stale?): reading {path}")
        return None
    return full


def load_json(path, required=False):
    # Committed results are packed (scripts/pack_results.py): a file may be there as
    # PATH.xz only, and a summary's whole form (with its curves) as NAME.full.json.xz.
    full = packed_full_summary(path)
    if full is not None:
        return full
    if not os.path.exists(path) and os.path.exists(path + ".xz"):
        path += ".xz"
    if not os.path.exists(path):
        if required:
            raise SystemExit(f"campaign_report: {path} does not exist")
        return None
    try:
        with (lzma.open(path, "rt") if path.endswith(".xz") else open(path)) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        if required:
            raise SystemExit(f"campaign_report: cannot read {path}: {e}")
        warn(f"skipping {path}: {e}")
        return None


def num(v):
    """float(v), or NaN for None / non-numbers (JSON writes NaN and infinities as null)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def arr(values):
    return np.array([num(v) for v in (values or [])], dtype=float)


def safe_name(s):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", str(s)).strip("_") or "x"


def fmt(v, digits=3):
    """`digits` significant digits; scientific notation outside [1e-3, 1e4); integers >= 100
    without decimals."""
    v = num(v)
    if math.isnan(v):
        return "–"
    if math.isinf(v):
        return "∞" if v > 0 else "-∞"
    if v == 0:
        return "0"
    a = abs(v)
    if a >= 1e4 or a < 1e-3:
        return f"{v:.{max(digits - 1, 0)}e}"
    if a >= 10 ** digits:
        return f"{v:.0f}"
    return f"{v:.{digits}g}"


def fmt_p(p):
    p = num(p)
    if math.isnan(p):
        return "–"
    if p < 1e-3:
        return f"{p:.2g}"
    return f"{p:.3f}"


def quartiles(values):
    x = np.asarray(values, dtype=float)
    x = x[~np.isnan(x)]
    if x.size == 0:
        return {"median": math.nan, "q1": math.nan, "q3": math.nan}
    q1, med, q3 = np.quantile(x, [0.25, 0.5, 0.75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3)}


def a12(a, b):
    """Vargha-Delaney A12 = P(a > b) + 0.5 P(a = b)."""
    a = np.asarray(a, dtype=float)[:, None]
    b = np.asarray(b, dtype=float)[None, :]
    return float(((a > b).sum() + 0.5 * (a == b).sum()) / (a.size * b.size))


def a12_magnitude(v):
    d = abs(v - 0.5)
    if d < 0.06 - 1e-12:
        return "negligible"
    if d < 0.14 - 1e-12:
        return "small"
    if d < 0.21 - 1e-12:
        return "medium"
    return "large"


def holm(p):
    p = np.asarray(p, dtype=float)
    order = np.argsort(p, kind="stable")
    adjusted = np.empty_like(p)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p) - rank) * p[i]))
        adjusted[i] = running
    return adjusted


def figure_file(figdir, name):
    return os.path.join(figdir, safe_name(name) + ".png")


def save(fig, path, dpi):
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


# Engineering units of a catalogue effect from its SI value: (factor, unit) by name prefix.
G0_MPS2 = 9.80665
ENGINEERING_UNITS = (
    ("accel_bias", 1e6 / G0_MPS2, "µg"),
    ("accel_scale", 1e6, "ppm"),
    ("gyro_bias", 180.0 / math.pi * 3600.0, "deg/h"),
    ("gyro_scale", 1e6, "ppm"),
    ("gyro_misalign", 1e6, "µrad"),
    ("accel_misalign", 1e6, "µrad"),
    ("lever_arm", 1.0, "m"),
    ("gnss_latency", 1e3, "ms"),
)


def engineering_unit(name):
    """(factor from SI, unit) of a parameter, or None when it is not in the table."""
    for prefix, factor, unit in ENGINEERING_UNITS:
        if name.startswith(prefix):
            return factor, unit
    return None


def plain_number(v, _pos=None):
    """Tick label without exponents ("70", "0.002", "1.5e+04" only past 1e4)."""
    if not math.isfinite(v):
        return ""
    if abs(v) >= 1e3:
        return f"{v:,.0f}"
    if v != 0 and abs(v) < 1e-3:
        return f"{v:.2g}"
    return f"{v:.3g}"


def positive(values):
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return x.size > 0 and bool(np.all(x > 0))


# ------------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------------


class Campaign:
    """Everything read from DIR, with the optional parts filled in from the run files."""

    def __init__(self, directory):
        self.dir = directory
        self.manifest = load_json(os.path.join(directory, "manifest.json")) or {}
        self.summary = load_json(os.path.join(directory, "summary.json")) or {}
        self.sweep = load_json(os.path.join(directory, "sweep.json"))
        self.config = self.manifest.get("config") or {}
        self.runs = self._load_runs()
        self.scenarios = self._scenario_order()
        self.labels = {s: self._algorithm_order(s) for s in self.scenarios}
        # A sweep's runs are one "algorithm" per setting: report only the best settings.
        self.sweep_labels = []
        if isinstance(self.sweep, dict):
            self.sweep_labels = [b.get("label") for b in self.sweep.get("best") or []
                                 if isinstance(b, dict) and b.get("label")]
            for scenario in self.scenarios:
                matched = [lab for lab in self.sweep_labels if lab in self.labels[scenario]]
                if matched:
                    self.labels[scenario] = matched

    def _load_runs(self):
        runs = {}
        root = os.path.join(self.dir, "runs")
        if not os.path.isdir(root):
            return runs
        for scenario in sorted(os.listdir(root)):
            sdir = os.path.join(root, scenario)
            if not os.path.isdir(sdir):
                continue
            for label in sorted(os.listdir(sdir)):
                adir = os.path.join(sdir, label)
                if not os.path.isdir(adir):
                    continue
                items = []
                for name in os.listdir(adir):
                    m = re.fullmatch(r"seed_(-?\d+)\.json(\.xz)?", name)
                    if not m or (m.group(2) and os.path.exists(os.path.join(adir, name[:-3]))):
                        continue
                    run = load_json(os.path.join(adir, name))
                    if isinstance(run, dict) and isinstance(run.get("result"), dict):
                        run.setdefault("seed", int(m.group(1)))
                        items.append(run)
                items.sort(key=lambda r: num(r.get("seed")))
                if items:
                    runs.setdefault(run_scenario(items[0], scenario), {})[label] = items
        return runs

    def _scenario_order(self):
        names = [s.get("name") for s in self.config.get("scenarios", []) if isinstance(s, dict)]
        names += list((self.summary.get("scenarios") or {}).keys()) + list(self.runs.keys())
        seen = []
        for n in names:
            in_summary = n in (self.summary.get("scenarios") or {})
            if n and n not in seen and (n in self.runs or in_summary):
                seen.append(n)
        return seen

    def _algorithm_order(self, scenario):
        labels = [a.get("label") for a in self.config.get("algorithms", []) if isinstance(a, dict)]
        labels += list(self.summary_algorithms(scenario).keys())
        labels += list(self.runs.get(scenario, {}).keys())
        seen = []
        for lab in labels:
            if lab and lab not in seen and (lab in self.runs.get(scenario, {})
                                            or lab in self.summary_algorithms(scenario)):
                seen.append(lab)
        return seen

    # -- summary accessors with fallbacks --------------------------------------------------------

    def summary_scenario(self, scenario):
        return (self.summary.get("scenarios") or {}).get(scenario) or {}

    def summary_algorithms(self, scenario):
        return self.summary_scenario(scenario).get("algorithms") or {}

    def algo_summary(self, scenario, label):
        return self.summary_algorithms(scenario).get(label) or {}

    def algo_runs(self, scenario, label):
        return self.runs.get(scenario, {}).get(label, [])

    def finals(self, scenario, label):
        return np.array([num(r["result"].get("fitness")) for r in self.algo_runs(scenario, label)])

    def n_runs(self, scenario, label):
        n = self.algo_summary(scenario, label).get("runs")
        return int(n) if isinstance(n, (int, float)) else len(self.algo_runs(scenario, label))

    def final_fitness(self, scenario, label):
        q = self.algo_summary(scenario, label).get("final_fitness")
        if isinstance(q, dict) and not math.isnan(num(q.get("median"))):
            return {k: num(q.get(k)) for k in ("median", "q1", "q3")}
        return quartiles(self.finals(scenario, label))

    def parameter_names(self, scenario):
        for label in self.labels[scenario]:
            for r in self.algo_runs(scenario, label):
                if isinstance(r.get("parameters"), list) and r["parameters"]:
                    # insid-run/3: objects with "name" (and sd, flags); before: names
                    return [str(p["name"]) if isinstance(p, dict) else str(p)
                            for p in r["parameters"]]
        names = []
        for label in self.labels[scenario]:
            for block in ("error_sigma", "error_vs_optimum_sigma"):
                for p in (self.algo_summary(scenario, label).get(block) or {}):
                    if p not in names:
                        names.append(p)
            for r in self.algo_runs(scenario, label):
                for p in estimate_in_sigma_units(r):
                    if p not in names:
                        names.append(p)
        return names

    def parameter_sigma_si(self):
        """{parameter: its sigma in SI} from the campaign config's "estimate" list."""
        out = {}
        for e in self.config.get("estimate") or []:
            if isinstance(e, dict) and isinstance(e.get("name"), str):
                v = num(e.get("sigma"))
                if math.isfinite(v) and v > 0:
                    out[e["name"]] = v
        return out

    def optimum_error_sigma(self, scenario):
        """{parameter: |reference optimum − truth| (σ)}: the error an exact minimiser of Eq. 15
        has on this data (the same in every run: error_sigma − error_vs_optimum_sigma)."""
        for label in self.labels[scenario]:
            for r in self.algo_runs(scenario, label):
                e, eo = r.get("error_sigma") or {}, r.get("error_vs_optimum_sigma") or {}
                out = {p: abs(num(e[p]) - num(eo[p])) for p in e if p in eo}
                if out and all(math.isfinite(v) for v in out.values()):
                    return out
        return {}

    def errors(self, scenario, label, block="error_sigma"):
        """{param: array of signed errors over runs} from the run files."""
        out = {}
        for r in self.algo_runs(scenario, label):
            for p, v in (r.get(block) or {}).items():
                out.setdefault(p, []).append(num(v))
        return {p: np.array(v) for p, v in out.items()}

    def median_abs_error(self, scenario, label, block="error_sigma"):
        """{param: median |error|}: summary's median_abs, else computed from runs."""
        out = {}
        for p, q in (self.algo_summary(scenario, label).get(block) or {}).items():
            if isinstance(q, dict) and "median_abs" in q:
                out[p] = num(q["median_abs"])
        for p, v in self.errors(scenario, label, block).items():
            if p not in out:
                out[p] = float(np.nanmedian(np.abs(v))) if v.size else math.nan
        return out

    def curve(self, scenario, label, axis):
        """(x, median, q1, q3) of best-so-far fitness vs 'iterations' or 'evaluations'."""
        c = self.algo_summary(scenario, label).get(f"curve_{axis}")
        if isinstance(c, dict) and c.get("x"):
            x, med = arr(c.get("x")), arr(c.get("median"))
            q1 = arr(c.get("q1")) if c.get("q1") else med
            q3 = arr(c.get("q3")) if c.get("q3") else med
            if x.size == med.size == q1.size == q3.size:
                return x, med, q1, q3
        return self._curve_from_runs(scenario, label, axis)

    def _curve_from_runs(self, scenario, label, axis):
        ys = []
        for r in self.algo_runs(scenario, label):
            res = r["result"]
            if axis == "iterations":
                y = arr([h.get("best_fitness") for h in res.get("history") or []])
            else:
                y = arr(res.get("best_per_evaluation"))
                if y.size == 0:  # step function from the history
                    hist = res.get("history") or []
                    ev = arr([h.get("evaluations") for h in hist])
                    bf = arr([h.get("best_fitness") for h in hist])
                    if ev.size and np.all(np.isfinite(ev)):
                        e = np.arange(1, int(np.nanmax(ev)) + 1)
                        idx = np.searchsorted(ev, e, side="left")
                        y = bf[np.minimum(idx, bf.size - 1)]
            if y.size:
                ys.append(np.minimum.accumulate(np.where(np.isnan(y), np.inf, y)))
        if not ys:
            return None
        n = max(y.size for y in ys)
        grid = np.array([np.concatenate([y, np.full(n - y.size, y[-1])]) for y in ys])
        grid[np.isinf(grid)] = np.nan
        x = np.arange(1, n + 1, dtype=float)
        with np.errstate(all="ignore"):
            q1, med, q3 = np.nanquantile(grid, [0.25, 0.5, 0.75], axis=0)
        return x, med, q1, q3

    def evaluations_per_iteration(self, scenario, label):
        steps = []
        for r in self.algo_runs(scenario, label):
            ev = arr([h.get("evaluations") for h in r["result"].get("history") or []])
            d = np.diff(ev[np.isfinite(ev)])
            if d.size:
                steps.append(float(np.median(d)))
            else:
                it, e = num(r["result"].get("iterations")), num(r["result"].get("evaluations"))
                if it > 0 and math.isfinite(e):
                    steps.append(e / it)
        return float(np.median(steps)) if steps else math.nan

    @staticmethod
    def equivalent_runs(run):
        """Work other than fitness evaluations, in INS runs (e.g. a Kalman filter pass)."""
        params = (run.get("result", {}).get("algorithm", {}) or {}).get("parameters") or {}
        v = num(params.get("equivalent_ins_runs"))
        return 0.0 if math.isnan(v) else v

    def median_cost(self, scenario, label):
        """Median over runs of evaluations + equivalent_runs (full INS runs spent)."""
        costs = [num(r["result"].get("evaluations")) + self.equivalent_runs(r)
                 for r in self.algo_runs(scenario, label)]
        costs = [v for v in costs if not math.isnan(v)]
        return float(np.median(costs)) if costs else math.nan

    def algorithm_name(self, scenario, label):
        for r in self.algo_runs(scenario, label):
            name = ((r["result"].get("algorithm") or {}).get("name"))
            if name:
                return str(name)
        for a in self.config.get("algorithms", []):
            if isinstance(a, dict) and a.get("label") == label and a.get("name"):
                return str(a["name"])
        return str(label)

    def ranking(self, scenario):
        medians = {lab: self.final_fitness(scenario, lab)["median"]
                   for lab in self.labels[scenario]}
        order = [lab for lab in (self.summary_scenario(scenario).get("ranking") or [])
                 if lab in medians]
        if len(order) != len(medians):
            order = sorted(medians, key=lambda lab: (math.isnan(medians[lab]), medians[lab]))
        return order, medians

    def pairwise(self, scenario):
        """List of dicts a, b, U, p, p_holm, a12, a12_magnitude, method; and whether computed."""
        entries = self.summary_scenario(scenario).get("pairwise")
        if isinstance(entries, list) and entries:
            shown = set(self.labels[scenario])
            out = [dict(e) for e in entries if isinstance(e, dict) and e.get("a") in shown
                   and e.get("b") in shown]
            ps = np.array([num(e.get("p")) for e in out])
            if any(math.isnan(num(e.get("p_holm"))) for e in out) and np.all(np.isfinite(ps)):
                for e, ph in zip(out, holm(ps)):
                    e["p_holm"] = float(ph)
            for e in out:
                if "a12_magnitude" not in e and not math.isnan(num(e.get("a12"))):
                    e["a12_magnitude"] = a12_magnitude(num(e["a12"]))
            return out, False
        labels = [lab for lab in self.labels[scenario] if self.finals(scenario, lab).size]
        out = []
        for i, j in itertools.combinations(range(len(labels)), 2):
            a = self.finals(scenario, labels[i])
            b = self.finals(scenario, labels[j])
            a, b = a[~np.isnan(a)], b[~np.isnan(b)]
            e = {"a": labels[i], "b": labels[j], "metric": "final_fitness"}
            if a.size and b.size and sps is not None:
                r = sps.mannwhitneyu(a, b, alternative="two-sided", use_continuity=True)
                ties = np.unique(np.concatenate([a, b])).size < a.size + b.size
                e.update(U=float(r.statistic), p=float(r.pvalue),
                         method="asymptotic" if (ties or min(a.size, b.size) > 8) else "exact")
            else:
                e.update(U=math.nan, p=math.nan, method="unavailable")
            if a.size and b.size:
                e["a12"] = a12(a, b)
                e["a12_magnitude"] = a12_magnitude(e["a12"])
            out.append(e)
        ps = np.array([num(e.get("p")) for e in out])
        if out and np.all(np.isfinite(ps)):
            for e, ph in zip(out, holm(ps)):
                e["p_holm"] = float(ph)
        return out, True


def run_scenario(run, fallback):
    s = run.get("scenario")
    return s if isinstance(s, str) and s else fallback


# ------------------------------------------------------------------------------------------------
# Figures
# ------------------------------------------------------------------------------------------------


def colors_for(labels):
    # Distinct colours for up to 20 algorithms (tab10's ten, then tab20's lighter shades).
    if len(labels) <= 10:
        cmap = plt.get_cmap("tab10")
        return {lab: cmap(i) for i, lab in enumerate(labels)}
    cmap = plt.get_cmap("tab20")
    order = list(range(0, 20, 2)) + list(range(1, 20, 2))
    return {lab: cmap(order[i % 20]) for i, lab in enumerate(labels)}


def plot_convergence(c, scenario, axis, path, dpi):
    labels = c.labels[scenario]
    colors = colors_for(labels)
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    all_y = []
    drawn = 0
    for lab in labels:
        curve = c.curve(scenario, lab, axis)
        if curve is None:
            continue
        x, med, q1, q3 = curve
        if len(x) == 1:
            # A one-pass method (the EKF-RTS): one point, on the evaluation axis at its cost in
            # INS runs (its evaluation plus its filter pass), so it is comparable to the curves.
            x_point = c.median_cost(scenario, lab) if axis == "evaluations" else x[0]
            ax.plot([x_point], med, color=colors[lab], marker="*", ms=11, ls="none",
                    label=f"{lab} (n={c.n_runs(scenario, lab)}, one pass"
                          + (", at its cost)" if axis == "evaluations" else ")"))
        else:
            ax.plot(x, med, color=colors[lab], lw=1.6, label=f"{lab} (n={c.n_runs(scenario, lab)})")
            ax.fill_between(x, q1, q3, color=colors[lab], alpha=0.2, lw=0)
        all_y.append(np.concatenate([med, q1, q3]))
        drawn += 1
    if drawn == 0:
        plt.close(fig)
        return False
    optimum = next((num(r.get("optimum_fitness")) for lab in labels
                    for r in c.algo_runs(scenario, lab)
                    if math.isfinite(num(r.get("optimum_fitness")))), math.nan)
    if math.isfinite(optimum):
        ax.axhline(optimum, color="tab:green", ls="--", lw=1.0,
                   label=f"data's own optimum ({plain_number(optimum)})")
    if positive(np.concatenate(all_y)):
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(FuncFormatter(plain_number))
    if axis == "evaluations":
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(plain_number))
        ax.set_xlabel("fitness evaluations (full INS runs)")
    else:
        ax.set_xlabel("iteration (generation)")
    ax.set_ylabel("best-so-far Eq. 15 fitness (m/s)")
    ax.set_title(f"{scenario}: best-so-far fitness, median and IQR over seeds", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7 if drawn > 6 else 8, ncol=2 if drawn > 6 else 1)
    fig.tight_layout()
    save(fig, path, dpi)
    return True


def boxplot(ax, data, labels, colors, log=None):
    """Box plots of `data` per label. log: True/False forces the y scale; None picks log when
    the values are positive and span more than a factor 100."""
    keep = [(d[np.isfinite(d)], lab) for d, lab in zip(data, labels)]
    keep = [(d, lab) for d, lab in keep if d.size]
    if not keep:
        return False
    pos = np.arange(1, len(keep) + 1)
    bp = ax.boxplot([d for d, _ in keep], positions=pos, widths=0.6, patch_artist=True,
                    showfliers=True, medianprops={"color": "black", "lw": 1.5})
    for patch, (_, lab) in zip(bp["boxes"], keep):
        patch.set_facecolor(colors[lab])
        patch.set_alpha(0.45)
    ax.set_xticks(pos)
    if len(keep) > 4:  # slanted, anchored at their right end: no overlap
        ax.set_xticklabels([lab for _, lab in keep], fontsize=8, rotation=40, ha="right",
                           rotation_mode="anchor")
    else:
        ax.set_xticklabels([lab for _, lab in keep], fontsize=8)
    values = np.concatenate([d for d, _ in keep])
    if log is None:
        log = positive(values) and values.max() / max(values.min(), 1e-300) > 100
    if log and positive(values):
        ax.set_yscale("log")
        if values.max() / values.min() < 1e3:  # few decades: label 1, 2, 5 of each
            ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(plain_number))
        ax.yaxis.set_minor_formatter(NullFormatter())
    ax.grid(alpha=0.3, axis="y")
    return True


def off_scale_labels(c, scenario, labels):
    """Methods whose median final fitness is more than 3x the median of the medians: drawn in a
    panel of their own so that they do not squash the others' boxes."""
    med = {lab: float(np.nanmedian(c.finals(scenario, lab))) if c.finals(scenario, lab).size
           else math.nan for lab in labels}
    finite = [v for v in med.values() if math.isfinite(v)]
    if len(finite) < 3:
        return []
    typical = float(np.median(finite))
    if typical <= 0:
        return []
    return [lab for lab in labels if math.isfinite(med[lab]) and med[lab] > 3 * typical]


FITNESS_LABEL = "final Eq. 15 fitness (m/s, summed over the GNSS epochs)"


def plot_final_fitness(c, scenario, path, dpi):
    labels = c.labels[scenario]
    colors = colors_for(labels)
    far = off_scale_labels(c, scenario, labels)
    near = [lab for lab in labels if lab not in far]
    optimum = next((num(r.get("optimum_fitness")) for lab in labels
                    for r in c.algo_runs(scenario, lab)
                    if math.isfinite(num(r.get("optimum_fitness")))), math.nan)
    if far:
        fig, (ax, ax_far) = plt.subplots(
            1, 2, figsize=(7.5, 4.4), gridspec_kw={"width_ratios": [max(len(near), 1), len(far) + 0.6]})
    else:
        fig, ax = plt.subplots(figsize=(6.8, 4.4))
        ax_far = None
    near_values = [c.finals(scenario, lab) for lab in near]
    flat = np.concatenate(near_values) if near_values else np.array([])
    flat = flat[np.isfinite(flat)]
    # Log when the boxes span more than a factor 10, so that no box is squashed by another.
    log = bool(flat.size) and positive(flat) and flat.max() / flat.min() > 10
    ok = boxplot(ax, near_values, near, colors, log=log)
    if not ok:
        plt.close(fig)
        return False
    if math.isfinite(optimum):
        ax.axhline(optimum, color="tab:green", ls="--", lw=1.0,
                   label=f"data's own optimum (reference, {plain_number(optimum)})")
        ax.legend(fontsize=7, loc="upper right")
    ax.set_ylabel(FITNESS_LABEL, fontsize=9)
    ax.yaxis.set_major_formatter(FuncFormatter(plain_number))
    ax.yaxis.set_minor_formatter(NullFormatter())
    if ax_far is not None:
        boxplot(ax_far, [c.finals(scenario, lab) for lab in far], far, colors, log=False)
        ax_far.yaxis.set_major_formatter(FuncFormatter(plain_number))
        ax_far.set_title("off the left scale\n(median > 3x typical)", fontsize=8)
    fig.suptitle(f"{scenario}: final fitness over seeds (lower is better)", fontsize=10)
    fig.tight_layout()
    save(fig, path, dpi)
    return True


def plot_parameter_errors(c, scenario, block, path, dpi):
    """|error| per parameter, one panel each, all on the same kind of scale (log when every
    error is positive), in σ on the left and in engineering units (deg/h, µg, ...) on the right;
    against truth, a line at the reference optimum's own error: the floor an exact minimiser
    of Eq. 15 reaches on this data."""
    labels = c.labels[scenario]
    errs = {lab: c.errors(scenario, lab, block) for lab in labels}
    params = [p for p in c.parameter_names(scenario) if any(p in e for e in errs.values())]
    for e in errs.values():  # parameters present only in the errors
        params += [p for p in e if p not in params]
    if not params:
        return False
    sigma_si = c.parameter_sigma_si()
    floor = c.optimum_error_sigma(scenario) if block == "error_sigma" else {}
    all_values = np.concatenate([np.abs(e[p]) for e in errs.values() for p in e if e[p].size]
                                or [np.array([])])
    log = positive(all_values)
    ncols = 2 if len(params) == 4 else min(3, len(params))
    nrows = math.ceil(len(params) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.6 * ncols, 3.6 * nrows), squeeze=False)
    colors = colors_for(labels)
    for k, p in enumerate(params):
        ax = axes.flat[k]
        data = [np.abs(errs[lab].get(p, np.array([]))) for lab in labels]
        if not boxplot(ax, data, labels, colors, log=log):
            ax.set_visible(False)
            continue
        ax.set_title(p, fontsize=9)
        ax.set_ylabel("|error| (σ)", fontsize=8)
        if p in floor and floor[p] > 0:
            ax.axhline(floor[p], color="tab:green", ls="--", lw=1.0,
                       label=f"reference optimum's error ({plain_number(floor[p])} σ)")
            ax.legend(fontsize=7, loc="lower left")
        eng = engineering_unit(p)
        if eng and p in sigma_si:
            factor = sigma_si[p] * eng[0]
            sec = ax.secondary_yaxis("right", functions=(lambda v, f=factor: v * f,
                                                         lambda v, f=factor: v / f))
            sec.set_ylabel(f"|error| ({eng[1]})", fontsize=8)
            sec.yaxis.set_major_formatter(FuncFormatter(plain_number))
            sec.yaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_formatter(FuncFormatter(plain_number))
        ax.yaxis.set_minor_formatter(NullFormatter())
    for k in range(len(params), nrows * ncols):
        axes.flat[k].set_visible(False)
    what = "|estimate − truth|" if block == "error_sigma" else "|estimate − reference optimum|"
    scale = "log scale" if log else "linear scale"
    fig.suptitle(f"{scenario}: {what} per parameter, in the parameter's σ (left) and in "
                 f"engineering units (right); {scale}", fontsize=10)
    fig.tight_layout()
    save(fig, path, dpi)
    return True


def first_position_run(c, scenario, label):
    for r in c.algo_runs(scenario, label):
        hist = r["result"].get("history") or []
        if any(isinstance(h.get("positions_sigma"), list) and h["positions_sigma"] for h in hist):
            return r
    return None


def plot_positions(c, scenario, label, run, path, dpi):
    hist = [h for h in run["result"].get("history") or [] if h.get("positions_sigma")]
    params = [str(p["name"]) if isinstance(p, dict) else str(p)
              for p in run.get("parameters") or []]
    dim = len(hist[0]["positions_sigma"][0]) if hist[0]["positions_sigma"] else 0
    if dim == 0:
        return None
    if len(params) != dim:
        params = list(estimate_in_sigma_units(run))[:dim]
        if len(params) != dim:
            params = [f"x{k}" for k in range(dim)]
    its, pos, best_traj, best_its = [], [], [], []
    best_f = math.inf
    best_x = None
    for idx, h in enumerate(hist):
        it = num(h.get("iteration"))
        it = float(idx) if math.isnan(it) else it
        x = np.array([[num(v) for v in p] for p in h["positions_sigma"]], dtype=float)
        its.append(it)
        pos.append(x)
        f = arr(h.get("positions_fitness"))
        if f.size == x.shape[0] and np.any(np.isfinite(f)):  # global best so far
            j = int(np.nanargmin(f))
            if f[j] < best_f:
                best_f, best_x = f[j], x[j]
        elif isinstance(h.get("best_sigma"), list):
            best_x = arr(h["best_sigma"])
        if best_x is not None:
            best_its.append(it)
            best_traj.append(best_x)
    truth = run.get("truth_sigma") or {}
    estimate = estimate_in_sigma_units(run)
    err_opt = run.get("error_vs_optimum_sigma") or {}
    premature_at = next((num(h.get("iteration", i)) for i, h in enumerate(hist)
                         if h.get("premature") is True), None)
    # A near-square grid without empty panels where possible (4 parameters: 2 x 2).
    ncols = min(dim, max(1, math.ceil(math.sqrt(dim))))
    nrows = math.ceil(dim / ncols)
    height = 2.8 * nrows + 0.9  # inches; the top 0.55 in hold the title and the legend
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.0 * ncols, height), squeeze=False)
    for k in range(dim):
        ax = axes.flat[k]
        xs = np.concatenate([np.full(p.shape[0], it) for it, p in zip(its, pos)])
        ys = np.concatenate([p[:, k] for p in pos])
        ax.scatter(xs, ys, s=4, alpha=0.35, color="tab:blue", lw=0, label="particles")
        if best_traj:
            ax.plot(best_its, [b[k] for b in best_traj], color="black", lw=1.3,
                    label="global best")
        name = params[k]
        # Truth: a wide translucent band; the optimum: a thin dashed line on top, so that both
        # stay visible where they coincide (the paper flight: within 0.003 σ).
        if name in truth and math.isfinite(num(truth[name])):
            ax.axhline(num(truth[name]), color="tab:red", lw=4.5, alpha=0.35, zorder=1,
                       label="truth")
        if name in estimate and name in err_opt:
            optimum = num(estimate[name]) - num(err_opt[name])
            if math.isfinite(optimum):
                ax.axhline(optimum, color="darkgreen", ls=(0, (4, 2)), lw=1.1, zorder=4,
                           label="reference optimum (Eq. 15)")
        if premature_at is not None and math.isfinite(premature_at):
            ax.axvline(premature_at, color="tab:orange", lw=0.8, alpha=0.8,
                       label="premature detected")
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
        if k % ncols == 0:
            ax.set_ylabel("position (σ)")
        if k >= dim - ncols:
            ax.set_xlabel("iteration")
    for k in range(dim, nrows * ncols):
        axes.flat[k].set_visible(False)
    handles, names = axes.flat[0].get_legend_handles_labels()
    fig.suptitle(f"{scenario}: {label} particle positions, seed {run.get('seed')}", fontsize=10)
    fig.legend(handles, names, loc="upper center", bbox_to_anchor=(0.5, 1.0 - 0.32 / height),
               fontsize=8, markerscale=3, ncol=len(names), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 1.0 - 0.55 / height))
    save(fig, path, dpi)
    return {"seed": run.get("seed"), "truth": bool(truth), "best": bool(best_traj),
            "premature": premature_at, "optimum": bool(err_opt)}


def sweep_value_index(values, v):
    for i, w in enumerate(values):
        if isinstance(w, (int, float)) and isinstance(v, (int, float)):
            if math.isclose(float(w), float(v), rel_tol=1e-9, abs_tol=1e-12):
                return i
        elif w == v:
            return i
    return None


def same_value(a, b):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)
    return a == b


def sweep_best(sweep):
    best = sweep.get("best") or []
    if best and isinstance(best[0], dict):
        return best[0].get("parameters", best[0])
    settings = [s for s in sweep.get("settings") or [] if isinstance(s, dict)]
    if not settings:
        return {}
    s = min(settings, key=lambda s: (math.isnan(setting_median(s)), setting_median(s)))
    return s.get("parameters") or {}


def setting_median(s):
    return num((s.get("final_fitness") or {}).get("median"))


def colourbar_plain(cb, values):
    """Five plain-number ticks from the lowest to the highest value (a log colourbar otherwise
    labels its minor ticks as "7×10¹")."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0 or v.min() == v.max():
        return
    ticks = np.geomspace(v.min(), v.max(), 5) if positive(v) else np.linspace(v.min(), v.max(), 5)
    cb.ax.yaxis.set_major_locator(FixedLocator(ticks))
    cb.ax.yaxis.set_major_formatter(FuncFormatter(plain_number))
    cb.ax.yaxis.set_minor_formatter(NullFormatter())


def plot_sweep_scatter(settings, params, best, figdir, dpi):
    """Random-search sweep (settings off the grid): median final fitness against each
    parameter (one swept parameter) or coloured scatter over each pair of parameters."""
    def values(p):
        return np.array([num((s.get("parameters") or {}).get(p)) for s in settings])
    med = np.array([setting_median(s) for s in settings])
    ok = np.isfinite(med)
    out = []
    if len(params) == 1:
        p = params[0]
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.scatter(values(p)[ok], med[ok], s=18)
        if p in best:
            ax.axvline(num(best[p]), color="red", lw=1, label="best setting")
            ax.legend(fontsize=8)
        if positive(med[ok]):
            ax.set_yscale("log")
        ax.set_xlabel(p)
        ax.set_ylabel("median final fitness (m/s)")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = figure_file(figdir, f"sweep_scatter_{p}")
        save(fig, path, dpi)
        return [(path, f"Random-search sweep: median final fitness per setting against {p}.")]
    for p, q in itertools.combinations(params, 2):
        x, y = values(p), values(q)
        keep = ok & np.isfinite(x) & np.isfinite(y)
        if not keep.any():
            continue
        fig, ax = plt.subplots(figsize=(6, 4.6))
        norm = LogNorm() if positive(med[keep]) and med[keep].max() > med[keep].min() else None
        sc = ax.scatter(x[keep], y[keep], c=med[keep], cmap="viridis_r", norm=norm, s=36,
                        edgecolors="k", linewidths=0.3)
        colourbar_plain(fig.colorbar(sc, ax=ax, label="median final fitness (m/s)"), med[keep])
        if p in best and q in best:
            ax.plot(num(best[p]), num(best[q]), marker="s", markersize=12, fillstyle="none",
                    color="red", mew=2)
        ax.set_xlabel(p)
        ax.set_ylabel(q)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = figure_file(figdir, f"sweep_scatter_{p}_{q}")
        save(fig, path, dpi)
        out.append((path, f"Random-search sweep: median final fitness of each setting over "
                          f"{p} × {q} (all other parameters vary too); red square: best."))
    return out


def plot_sweep(sweep, figdir, dpi):
    """Heatmaps of median final fitness over each pair of swept parameters (the others at
    their best value); a line plot when only one parameter is swept. Returns (path, caption)."""
    grid = {p: list(v) for p, v in (sweep.get("grid") or {}).items() if isinstance(v, list)}
    settings = [s for s in sweep.get("settings") or [] if isinstance(s, dict)]
    params = [p for p, v in grid.items() if len(v) > 1]
    best = sweep_best(sweep)
    out = []
    on_grid = all(all(sweep_value_index(grid[p], (s.get("parameters") or {}).get(p)) is not None
                      for p in params) for s in settings)
    if not on_grid:
        return plot_sweep_scatter(settings, list(grid), best, figdir, dpi)
    if len(params) == 1:
        p = params[0]
        vals = grid[p]
        med, lo, hi = [], [], []
        for v in vals:
            match = [s for s in settings if same_value((s.get("parameters") or {}).get(p), v)]
            q = (match[0].get("final_fitness") or {}) if match else {}
            med.append(num(q.get("median")))
            lo.append(num(q.get("q1")))
            hi.append(num(q.get("q3")))
        fig, ax = plt.subplots(figsize=(6, 4))
        x = np.arange(len(vals))
        med, lo, hi = np.array(med), np.array(lo), np.array(hi)
        ax.errorbar(x, med, yerr=[med - lo, hi - med], fmt="o-", capsize=3)
        ax.set_xticks(x)
        ax.set_xticklabels([fmt(v) for v in vals])
        ax.set_xlabel(p)
        ax.set_ylabel("median final fitness (m/s, IQR bars)")
        if positive(np.concatenate([med, lo, hi])):
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = figure_file(figdir, f"sweep_{p}")
        save(fig, path, dpi)
        out.append((path, f"Sweep of {p}: median final fitness with IQR bars per value."))
        return out
    for p, q in itertools.combinations(params, 2):
        others = [o for o in grid if o not in (p, q)]
        M = np.full((len(grid[p]), len(grid[q])), np.nan)
        relaxed = False
        for attempt in (0, 1):
            for s in settings:
                sp = s.get("parameters") or {}
                if attempt == 0 and not all(o in best and same_value(sp.get(o), best[o])
                                            for o in others):
                    continue
                i, j = sweep_value_index(grid[p], sp.get(p)), sweep_value_index(grid[q], sp.get(q))
                if i is None or j is None:
                    continue
                m = setting_median(s)
                if math.isnan(M[i, j]) or m < M[i, j]:  # attempt 1: best over the others
                    M[i, j] = m
            if np.any(np.isfinite(M)):
                break
            relaxed = True
        if not np.any(np.isfinite(M)):
            continue
        fig, ax = plt.subplots(figsize=(1.0 + 0.75 * len(grid[q]) + 1.5, 1.0 + 0.6 * len(grid[p])))
        finite = M[np.isfinite(M)]
        norm = LogNorm(vmin=finite.min(), vmax=finite.max()) if (
            positive(finite) and finite.max() > finite.min()) else None
        im = ax.imshow(np.ma.masked_invalid(M), origin="lower", aspect="auto", cmap="viridis_r",
                       norm=norm)
        colourbar_plain(fig.colorbar(im, ax=ax, label="median final fitness (m/s)"), finite)
        ax.set_xticks(range(len(grid[q])))
        ax.set_xticklabels([fmt(v) for v in grid[q]], fontsize=8)
        ax.set_yticks(range(len(grid[p])))
        ax.set_yticklabels([fmt(v) for v in grid[p]], fontsize=8)
        ax.set_xlabel(q)
        ax.set_ylabel(p)
        if M.size <= 100:
            for i in range(M.shape[0]):
                for j in range(M.shape[1]):
                    if np.isfinite(M[i, j]):
                        r, g, b, _ = im.cmap(im.norm(M[i, j]))
                        dark = 0.299 * r + 0.587 * g + 0.114 * b < 0.5
                        ax.text(j, i, fmt(M[i, j], 2), ha="center", va="center", fontsize=7,
                                color="white" if dark else "black")
        bi, bj = sweep_value_index(grid[p], best.get(p)), sweep_value_index(grid[q], best.get(q))
        if bi is not None and bj is not None:
            ax.add_patch(plt.Rectangle((bj - 0.5, bi - 0.5), 1, 1, fill=False, edgecolor="red",
                                       lw=2.5))
        fixed = ", ".join(f"{o} = {fmt(best[o])}" for o in others if o in best)
        ax.set_title(f"{p} × {q}" + (f" ({fixed})" if fixed and not relaxed else ""), fontsize=9)
        fig.tight_layout()
        path = figure_file(figdir, f"sweep_heatmap_{p}_{q}")
        save(fig, path, dpi)
        if relaxed:
            how = "each cell is the best over the other parameters (no setting matched the best " \
                  "values of the others exactly)"
        elif others:
            how = f"other parameters at their best value ({fixed})"
        else:
            how = "all swept parameters shown"
        out.append((path, f"Median final fitness over {p} × {q}; {how}; red box: best setting."))
    return out


# ------------------------------------------------------------------------------------------------
# Report
# ------------------------------------------------------------------------------------------------


def describe_target(t):
    if not isinstance(t, dict):
        return str(t)
    kind, value = t.get("kind"), t.get("value")
    if kind == "relative_fitness_gap":
        return f"(f − f_opt) ≤ {fmt(value)}·|f_opt|"
    if kind == "max_abs_error_vs_optimum_sigma":
        return f"max |error vs optimum| ≤ {fmt(value)} σ"
    if kind == "max_abs_error_sigma":
        return f"max |error| ≤ {fmt(value)} σ"
    if "description" in t:
        return str(t["description"])
    return ", ".join(f"{k}={fmt(v) if isinstance(v, (int, float)) else v}" for k, v in t.items())


def md_table(header, rows):
    def cell(c):
        return str(c).replace("|", "\\|").replace("\n", " ")
    lines = ["| " + " | ".join(cell(h) for h in header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def find_pair(pairs, x, y):
    """The pairwise entry of x vs y, with a12 re-expressed as A12(x, y) = P(x > y)."""
    for e in pairs:
        if e.get("a") == x and e.get("b") == y:
            return e, num(e.get("a12"))
        if e.get("a") == y and e.get("b") == x:
            a = num(e.get("a12"))
            return e, (1.0 - a if not math.isnan(a) else a)
    return None, math.nan


def verdict_paragraph(c, scenario, pairs, alpha):
    order, medians = c.ranking(scenario)
    order = [lab for lab in order if not math.isnan(medians[lab])]
    if not order:
        return "No run finished, so there is nothing to compare."
    n_text = ", ".join(f"{lab} {c.n_runs(scenario, lab)}" for lab in order)
    if len(order) == 1:
        return (f"Only {order[0]} has results (median final fitness {fmt(medians[order[0]])}); "
                f"there is nothing to compare it with.")
    best, second = order[0], order[1]
    mb, ms = medians[best], medians[second]
    s = []
    if mb == ms:
        s.append(f"{best} and {second} share the lowest median final fitness ({fmt(mb)}).")
    elif mb > 0 and ms > 0 and ms / mb < 1.01:
        s.append(f"{best} has the lowest median final fitness ({mb:.6g}); the runner-up "
                 f"{second} is within {fmt(100 * (ms / mb - 1))} % of it ({ms:.6g}).")
    elif mb > 0 and ms > 0:
        s.append(f"{best} has the lowest median final fitness ({fmt(mb)}); the runner-up "
                 f"{second} has a median {fmt(ms / mb)} times higher ({fmt(ms)}).")
    else:
        s.append(f"{best} has the lowest median final fitness ({fmt(mb)}); the runner-up "
                 f"{second} has {fmt(ms)} (difference {fmt(ms - mb)}).")
    e, a = find_pair(pairs, best, second)
    p_holm = num(e.get("p_holm")) if e else math.nan
    if e is None or math.isnan(p_holm):
        s.append(f"No test of {best} against {second} is available, so the data cannot say "
                 f"whether they differ.")
    else:
        mag = a12_magnitude(a) if not math.isnan(a) else "unknown"
        prob = (f"a {best} run ends below a {second} run with probability {fmt(1 - a, 2)} "
                f"(ties count half; A12({best}, {second}) = {fmt(a, 2)}, {mag} effect)"
                if not math.isnan(a) else "the effect size is not available")
        if p_holm < alpha:
            s.append(f"The difference is significant after Holm correction (two-sided "
                     f"Mann-Whitney, p_Holm = {fmt_p(p_holm)} < {alpha:g}): {prob}.")
        else:
            s.append(f"The difference is not significant after Holm correction (p_Holm = "
                     f"{fmt_p(p_holm)} ≥ {alpha:g}): the data do not separate {best} from "
                     f"{second}; {prob}.")
    if len(order) > 2:
        better, unresolved = [], []
        for other in order[2:]:
            e, a = find_pair(pairs, best, other)
            ph = num(e.get("p_holm")) if e else math.nan
            if not math.isnan(ph) and ph < alpha and medians[other] > mb:
                better.append(f"{other} (p_Holm = {fmt_p(ph)}, A12 = {fmt(a, 2)}, "
                              f"{a12_magnitude(a) if not math.isnan(a) else '?'})")
            else:
                unresolved.append(f"{other} (p_Holm = {fmt_p(ph)})")
        if better:
            s.append(f"{best} is significantly better than " + "; ".join(better) + ".")
        if unresolved:
            s.append(f"The data do not separate {best} from " + "; ".join(unresolved) + ".")
    # Parameter accuracy.
    block = "error_sigma"
    errs = {lab: c.median_abs_error(scenario, lab, block) for lab in order}
    if not any(errs.values()):
        block = "error_vs_optimum_sigma"
        errs = {lab: c.median_abs_error(scenario, lab, block) for lab in order}
    params = sorted({p for e in errs.values() for p in e})
    if params:
        wins = {lab: 0 for lab in order}
        for p in params:
            vals = {lab: errs[lab].get(p, math.nan) for lab in order}
            vals = {lab: v for lab, v in vals.items() if not math.isnan(v)}
            if vals:
                wins[min(vals, key=vals.get)] += 1
        top = max(wins, key=wins.get)
        what = "truth" if block == "error_sigma" else "reference optimum"
        s.append(f"On parameter accuracy (median |error| against the {what}, in σ), {top} is "
                 f"the most accurate on {wins[top]} of {len(params)} parameters.")
    s.append(f"Runs per algorithm: {n_text}.")
    return " ".join(s)


def statistics_tables(c, scenario):
    labels = c.labels[scenario]
    order, _ = c.ranking(scenario)
    labels = order + [lab for lab in labels if lab not in order]
    targets = []
    for lab in labels:
        for t in c.algo_summary(scenario, lab).get("success") or []:
            d = describe_target(t.get("target"))
            if d not in targets:
                targets.append(d)
    header = ["algorithm", "runs", "final fitness median [q1, q3]", "evals/iteration",
              "cost, INS runs (median)", "wall s (median)"]
    rows, success_rows = [], []
    for lab in labels:
        q = c.final_fitness(scenario, lab)
        wall = c.algo_summary(scenario, lab).get("wall_s") or {}
        wall_med = num(wall.get("median"))
        if math.isnan(wall_med):
            w = [num(r["result"].get("wall_s")) for r in c.algo_runs(scenario, lab)]
            wall_med = float(np.nanmedian(w)) if w and not all(map(math.isnan, w)) else math.nan
        succ = {describe_target(t.get("target")): t
                for t in c.algo_summary(scenario, lab).get("success") or []}
        cells = []
        for t in targets:
            e = succ.get(t)
            if e is None:
                cells.append("–")
                continue
            rate = num(e.get("rate"))
            ert = num(e.get("ert_evaluations"))
            if math.isnan(ert) and rate == 0:
                ert = math.inf
            cells.append(f"{fmt(100 * rate, 2)} % / {fmt(ert)}")
        rows.append([lab, c.n_runs(scenario, lab),
                     f"{fmt(q['median'])} [{fmt(q['q1'])}, {fmt(q['q3'])}]",
                     fmt(c.evaluations_per_iteration(scenario, lab)),
                     fmt(c.median_cost(scenario, lab)), fmt(wall_med)])
        success_rows.append([lab] + cells)
    text = [md_table(header, rows)]
    if any(c.equivalent_runs(r) for lab in labels for r in c.algo_runs(scenario, lab)):
        text.append("Cost counts full INS runs: the fitness and residual evaluations, plus, for "
                    "a method that does other work (the EKF-RTS's filter and smoother pass), "
                    "that work in equivalent INS runs as the method measured it "
                    "(`equivalent_ins_runs` in its parameters).")
    if targets:
        text.append("Success rate and aRT (evaluations) per target; aRT is COCO's average "
                    "running time, the evaluations of all runs (successful or not) divided by "
                    "the number of successful runs: ∞ when no run succeeded, – when not "
                    "computed:\n\n" + md_table(["algorithm"] + targets, success_rows))
    for block, what in (("error_sigma", "estimate − truth"),
                        ("error_vs_optimum_sigma", "estimate − reference optimum")):
        errs = {lab: c.median_abs_error(scenario, lab, block) for lab in labels}
        params = [p for p in c.parameter_names(scenario) if any(p in e for e in errs.values())]
        if not params:
            continue
        rows = []
        for lab in labels:
            vals = [errs[lab].get(p, math.nan) for p in params]
            finite = [v for v in vals if not math.isnan(v)]
            rows.append([lab] + [fmt(v) for v in vals]
                        + [fmt(float(np.median(finite))) if finite else "–"])
        text.append(f"Median |{what}| per parameter, in units of the parameter's σ:\n\n"
                    + md_table(["algorithm"] + params + ["median over parameters"], rows))
    return "\n\n".join(text)


def pairwise_table(pairs, alpha):
    rows = []
    for e in pairs:
        ph = num(e.get("p_holm"))
        a = num(e.get("a12"))
        mag = e.get("a12_magnitude") or (a12_magnitude(a) if not math.isnan(a) else "–")
        rows.append([e.get("a"), e.get("b"), fmt(e.get("U")), fmt_p(e.get("p")), fmt_p(ph),
                     "yes" if (not math.isnan(ph) and ph < alpha) else "no", fmt(a, 2), mag,
                     e.get("method", "–")])
    return md_table(["a", "b", "U (of a)", "p", "p Holm", f"p Holm < {alpha:g}",
                     "A12 = P(a > b)", "magnitude", "method"], rows)


def image(md_dir, path, caption):
    rel = os.path.relpath(path, md_dir).replace(os.sep, "/")
    return f"![{caption}]({rel})\n\n*{caption}*"


def provenance(c):
    m, cfg = c.manifest, c.config
    build = m.get("build") or {}
    seeds = cfg.get("seeds")
    n_seeds = len(seeds) if isinstance(seeds, list) else seeds
    items = [
        ("campaign", cfg.get("name") or c.summary.get("campaign")),
        ("git revision", build.get("git_revision")),
        ("compiler", build.get("compiler")),
        ("host", m.get("host")),
        ("cores / threads", f"{m.get('cores', '–')} / {m.get('threads', '–')}"
         if ("cores" in m or "threads" in m) else None),
        ("seeds", n_seeds),
        ("max iterations", cfg.get("max_iterations")),
        ("max evaluations", cfg.get("max_evaluations")),
        ("alignment", cfg.get("alignment")),
    ]
    algos = [a for a in cfg.get("algorithms", []) if isinstance(a, dict)]
    if c.sweep:  # one algorithm entry per setting: the sweep section lists them
        algos = []
    lines = [f"- {k}: {v}" for k, v in items if v not in (None, "", [])]
    for a in algos:
        params = a.get("parameters") or {}
        ptxt = ", ".join(f"{k} = {v}" for k, v in params.items()) or "defaults"
        lines.append(f"- {a.get('label')}: `{a.get('name')}` ({ptxt})")
    return "\n".join(lines)


def evaluations_caption(c, scenario):
    per = {lab: c.evaluations_per_iteration(scenario, lab) for lab in c.labels[scenario]}
    known = ", ".join(f"{lab} {fmt(v)}" for lab, v in per.items() if not math.isnan(v))
    vals = [v for v in per.values() if not math.isnan(v)]
    unequal = len(vals) > 1 and (max(vals) - min(vals)) > 1e-9
    text = (f"Best-so-far fitness vs fitness evaluations for {scenario} (median line, IQR band, "
            f"log axes). The paper's iteration axis (Figure 9) is not equal-cost: ")
    if known:
        text += f"evaluations per iteration here are {known}"
        text += (", so the evaluation axis is the fair comparison." if unequal
                 else "; in this campaign they happen to be equal.")
    else:
        text += "GA spends 20 evaluations per generation, the others 10."
    return text


def write_report(c, figdir, alpha, dpi):
    md_dir = c.dir
    out = []
    title = c.config.get("name") or c.summary.get("campaign") or os.path.basename(
        os.path.abspath(c.dir))
    out.append(f"# Campaign report: {title}\n")
    out.append(f"Generated by `scripts/campaign_report.py` on "
               f"{datetime.datetime.now().strftime('%Y-%m-%d %H:%M')} from `{c.dir}`. Lower "
               f"fitness is better. Tests: two-sided Mann-Whitney U on the final fitness, Holm "
               f"correction over each scenario's pairs, Vargha-Delaney A12 (A12 = P(a > b): "
               f"below 0.5 means a tends to end lower); significance level α = {alpha:g}.\n")
    prov = provenance(c)
    if prov:
        out.append("## Setup\n\n" + prov + "\n")
    figures = []
    winners = []
    if c.sweep:
        out.append(sweep_section(c, figdir, md_dir, dpi, figures))
    for scenario in c.scenarios:
        if not c.labels[scenario]:
            continue
        out.append(f"## Scenario `{scenario}`\n")
        if c.sweep:
            out.append(f"Restricted to the sweep's {len(c.labels[scenario])} best settings "
                       f"(labels as in the sweep table); p-values are Holm-corrected over the "
                       f"pairs of all settings when summary.json provides them.\n")
        pairs, computed = c.pairwise(scenario)
        order, medians = c.ranking(scenario)
        if order and not math.isnan(medians[order[0]]):
            winners.append((scenario, order[0]))
        out.append("### Result\n\n" + verdict_paragraph(c, scenario, pairs, alpha) + "\n")
        out.append("### Statistics\n\n" + statistics_tables(c, scenario) + "\n")
        if pairs:
            note = (" (computed by this script from the run files: summary.json has no "
                    "pairwise tests)" if computed else "")
            out.append(f"### Pairwise tests on the final fitness{note}\n\n"
                       + pairwise_table(pairs, alpha) + "\n")
        out.append("### Figures\n")
        path = figure_file(figdir, f"convergence_iterations_{scenario}")
        if plot_convergence(c, scenario, "iterations", path, dpi):
            figures.append(path)
            out.append(image(md_dir, path, f"Figure 9 analogue for {scenario}: best-so-far "
                             f"fitness vs iteration, median line and IQR band over seeds, log "
                             f"scale.") + "\n")
        path = figure_file(figdir, f"convergence_evaluations_{scenario}")
        if plot_convergence(c, scenario, "evaluations", path, dpi):
            figures.append(path)
            out.append(image(md_dir, path, evaluations_caption(c, scenario)) + "\n")
        path = figure_file(figdir, f"final_fitness_{scenario}")
        if plot_final_fitness(c, scenario, path, dpi):
            figures.append(path)
            out.append(image(md_dir, path, f"Final fitness over seeds for {scenario}.") + "\n")
        for block, name, what in (("error_sigma", "parameter_errors", "injected truth"),
                                  ("error_vs_optimum_sigma", "parameter_errors_vs_optimum",
                                   "reference optimum")):
            path = figure_file(figdir, f"{name}_{scenario}")
            if plot_parameter_errors(c, scenario, block, path, dpi):
                figures.append(path)
                out.append(image(md_dir, path, f"Final |error| against the {what} per parameter "
                                 f"and algorithm for {scenario}, in units of each parameter's "
                                 f"σ.") + "\n")
        for lab in c.labels[scenario]:
            if c.algorithm_name(scenario, lab).lower() not in POSITION_ALGORITHMS and \
                    lab.lower() not in POSITION_ALGORITHMS:
                continue
            run = first_position_run(c, scenario, lab)
            if run is None:
                continue
            path = figure_file(figdir, f"positions_{lab}_{scenario}_seed{run.get('seed')}")
            info = plot_positions(c, scenario, lab, run, path, dpi)
            if info is None:
                continue
            figures.append(path)
            parts = [f"Figures 10-13 analogue: {lab} particle positions per dimension over "
                     f"iterations for {scenario}, seed {info['seed']} (dots: particles)"]
            if info["best"]:
                parts.append("black line: global best so far")
            if info["truth"]:
                parts.append("red dashed: injected truth")
            if info["optimum"]:
                parts.append("green dotted: reference optimum of the fitness")
            if info["premature"] is not None:
                parts.append(f"orange: premature convergence detected at iteration "
                             f"{fmt(info['premature'])}")
            out.append(image(md_dir, path, "; ".join(parts) + ".") + "\n")
    friedman = c.summary.get("friedman")
    if isinstance(friedman, dict):
        out.append("## Across scenarios\n")
        ranks = friedman.get("ranks") or {}
        stat, p = num(friedman.get("statistic")), num(friedman.get("p"))
        if ranks:
            rows = sorted(ranks.items(), key=lambda kv: num(kv[1]))
            out.append(md_table(["algorithm", "mean rank (1 = best)"],
                                [[k, fmt(v)] for k, v in rows]) + "\n")
        if math.isnan(p):
            out.append(f"Friedman test not available ({friedman.get('note') or 'undefined'}).\n")
        else:
            verdict = ("the algorithms' ranks differ significantly across scenarios"
                       if p < alpha else "the ranks across scenarios do not differ significantly")
            out.append(f"Friedman test over {len(c.scenarios)} scenarios (blocks) on the median "
                       f"final fitness: χ² = {fmt(stat)}, p = {fmt_p(p)}; at α = {alpha:g} "
                       f"{verdict}.\n")
    if len(winners) > 1:
        out.append("Lowest median final fitness per scenario: "
                   + "; ".join(f"{s}: {w}" for s, w in winners) + ".\n")
    report = os.path.join(c.dir, "report.md")
    tmp = report + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(out).rstrip() + "\n")
    os.replace(tmp, report)
    return report, figures


# DVPIO parameters that act only once its premature test (Eq. 10) has fired, and the test's own
# threshold: when the test never fires, settings differing only in these give identical runs.
DVPIO_PREMATURE_PARAMETERS = {"dist_threshold", "d_initial", "d0", "d_min", "d_max",
                              "shrink_without_gain"}


def setting_runs(c, label):
    """The run files of a sweep setting (any scenario), by seed."""
    for scenario in c.runs:
        if label in c.runs[scenario]:
            return {num(r.get("seed")): r for r in c.runs[scenario][label]}
    return {}


def run_fingerprint(run):
    """What makes two runs the same result: final fitness, evaluations and the estimate."""
    res = run.get("result") or {}
    est = estimate_in_sigma_units(run)
    return (num(res.get("fitness")), num(res.get("evaluations")),
            tuple(sorted((p, num(v)) for p, v in est.items())))


def sweep_ties(c, settings):
    """Groups (lists of settings, >= 2) whose runs are identical, with how it is known and, when
    it can be known, why: [(group, basis, reason)]. Basis "runs": every seed's run file gives the
    same final fitness, evaluations and estimate; "summary": no run files, but every summary
    statistic in sweep.json is equal."""
    groups = {}
    for s in settings:
        label = s.get("label")
        runs = setting_runs(c, label) if label else {}
        if runs:
            key = ("runs", tuple(sorted((seed, run_fingerprint(r)) for seed, r in runs.items())))
        else:
            q, e = s.get("final_fitness") or {}, s.get("error_sigma_norm") or {}
            key = ("summary", tuple(num(d.get(k)) for d in (q, e) for k in ("median", "q1", "q3"))
                   + tuple(num(v) for v in (s.get("median_ci95") or [])))
            if any(math.isnan(v) for v in key[1]):
                continue
        groups.setdefault(key, []).append(s)
    out = []
    for key, group in groups.items():
        if len(group) < 2:
            continue
        params = [g.get("parameters") or {} for g in group]
        differing = sorted({p for sp in params for p in sp
                            if any(not same_value(sp.get(p), o.get(p)) for o in params)})
        reason = ""
        algorithm = str(c.sweep.get("algorithm", "")).lower()
        base = {p[:-6] if p.endswith("_sigma") else p for p in differing}
        if algorithm == "dvpio" and base and base <= DVPIO_PREMATURE_PARAMETERS and key[0] == "runs":
            fired = any(h.get("premature") is True for g in group
                        for r in setting_runs(c, g.get("label")).values()
                        for h in (r.get("result") or {}).get("history") or [])
            has_flags = any("premature" in h for g in group
                            for r in setting_runs(c, g.get("label")).values()
                            for h in (r.get("result") or {}).get("history") or [])
            if has_flags and not fired:
                reason = ("DVPIO's premature test (Eq. 10) never fired in these runs, so "
                          + ", ".join(differing) + " never acted")
        out.append((group, key[0], differing, reason))
    return out


def competition_ranks(top, ties):
    """Rank texts for the table: tied settings share the rank of the first, written "1=" """
    tied_with = {}
    for group, _, _, _ in ties:
        labels = [g.get("label") for g in group]
        for lab in labels:
            tied_with[lab] = set(labels)
    ranks = []
    for i, s in enumerate(top):
        lab = s.get("label")
        first = next((j for j in range(i + 1) if top[j].get("label") in tied_with.get(lab, ())),
                     i)
        ranks.append(f"{first + 1}=" if lab in tied_with else str(i + 1))
    return ranks


def sweep_section(c, figdir, md_dir, dpi, figures):
    sw = c.sweep
    out = [f"## Parameter sweep: {sw.get('algorithm', '?')}\n"]
    grid = sw.get("grid") or {}
    n_random = sw.get("random_settings")
    if isinstance(n_random, (int, float)) and n_random > 0:
        out.append(f"{int(n_random)} random settings drawn uniformly within the ranges of: "
                   + "; ".join(f"{p} ∈ [{fmt(min(v))}, {fmt(max(v))}]" for p, v in grid.items()
                               if v) + ".\n")
    elif grid:
        out.append("Grid: " + "; ".join(f"{p} ∈ {{{', '.join(fmt(v) for v in vals)}}}"
                                         for p, vals in grid.items()) + ".\n")
    settings = [s for s in sw.get("settings") or [] if isinstance(s, dict)]
    top = [s for s in (sw.get("best") or []) if isinstance(s, dict) and "parameters" in s]
    if not top:
        top = sorted(settings, key=lambda s: (math.isnan(setting_median(s)), setting_median(s)))
    top = top[:10]
    params = list(grid) or sorted({p for s in top for p in (s.get("parameters") or {})})
    ties = sweep_ties(c, settings)
    ranks = competition_ranks(top, ties)
    rows = []
    for rank, s in zip(ranks, top):
        sp = s.get("parameters") or {}
        q = s.get("final_fitness") or {}
        en = s.get("error_sigma_norm") or {}
        ci = s.get("median_ci95") or []
        ci_txt = f"[{fmt(ci[0])}, {fmt(ci[1])}]" if isinstance(ci, list) and len(ci) == 2 else "–"
        rows.append([rank, s.get("label", "–")]
                    + [fmt(sp.get(p)) if isinstance(sp.get(p), (int, float))
                       else str(sp.get(p, "–")) for p in params]
                    + [f"{fmt(q.get('median'))} [{fmt(q.get('q1'))}, {fmt(q.get('q3'))}]", ci_txt,
                       f"{fmt(en.get('median'))} [{fmt(en.get('q1'))}, {fmt(en.get('q3'))}]"])
    if rows:
        out.append(f"Best settings (of {len(settings)}), by median final fitness:\n")
        out.append(md_table(["rank", "label"] + params + ["final fitness median [q1, q3]",
                                                 "95 % CI of the median",
                                                 "‖error‖ (σ) median [q1, q3]"], rows) + "\n")
        for group, basis, differing, reason in ties:
            labels = ", ".join(g.get("label", "?") for g in group)
            how = ("gave identical runs on every seed (same final fitness, evaluations and "
                   "estimate)" if basis == "runs" else
                   "have identical summary statistics (no run files to compare seed by seed)")
            why = (f" Why: {reason}." if reason else
                   " Why they coincide is not known from the files"
                   + (f" (they differ in {', '.join(differing)})." if differing else "."))
            out.append(f"**Tie**: settings {labels} {how}: they are one result, ranked equal "
                       f"(\"=\"), not an order.{why}\n")
        if len(top) > 1 and not any(
                {top[0].get("label"), top[1].get("label")} <= {g.get("label") for g in group}
                for group, _, _, _ in ties):
            ci0, ci1 = top[0].get("median_ci95"), top[1].get("median_ci95")
            if isinstance(ci0, list) and isinstance(ci1, list) and len(ci0) == len(ci1) == 2:
                overlap = num(ci0[1]) >= num(ci1[0]) and num(ci1[1]) >= num(ci0[0])
                out.append("The 95 % confidence intervals of the two best settings' medians "
                           + ("overlap: the sweep does not single out one best setting."
                              if overlap else "do not overlap: the best setting is clearly "
                              "ahead of the runner-up.") + "\n")
    for path, caption in plot_sweep(sw, figdir, dpi):
        figures.append(path)
        out.append(image(md_dir, path, caption) + "\n")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Figures (DIR/figures/*.png) and a Markdown report (DIR/report.md) from a "
                    "campaign or sweep directory written by `insid bench` / `insid sweep`.")
    ap.add_argument("dir", metavar="DIR", help="campaign (or sweep) results directory")
    ap.add_argument("--alpha", type=float, default=0.05,
                    help="significance level for the Holm-corrected tests (default 0.05)")
    ap.add_argument("--dpi", type=int, default=110, help="figure resolution (default 110)")
    args = ap.parse_args(argv)
    if not os.path.isdir(args.dir):
        ap.error(f"{args.dir} is not a directory")
    if not 0 < args.alpha < 1:
        ap.error("--alpha must be in (0, 1)")
    c = Campaign(args.dir)
    if not c.scenarios and not c.sweep:
        raise SystemExit(f"campaign_report: {args.dir} has no runs, summary.json or sweep.json")
    figdir = os.path.join(args.dir, "figures")
    os.makedirs(figdir, exist_ok=True)
    report, figures = write_report(c, figdir, args.alpha, args.dpi)
    print(f"campaign_report: wrote {report} and {len(figures)} figures in {figdir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
