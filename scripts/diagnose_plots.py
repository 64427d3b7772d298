#!/usr/bin/env python3
"""Figures for `insid diagnose --report`: residuals before/after over time, RMS per flight
phase, candidate scores per iteration.

usage: diagnose_plots.py --report REPORT.json --series SERIES.csv --prefix PATH_PREFIX
writes PATH_PREFIX_residuals.png, PATH_PREFIX_phases.png, PATH_PREFIX_scores.png
(Debian's python3-matplotlib / numpy only.)
"""
import argparse
import csv
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load_series(path):
    t, phase, eb, nb, ea, na = [], [], [], [], [], []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            t.append(float(row["t_s"]))
            phase.append(row["phase"])
            eb.append(float(row["dvE_before_mps"]))
            nb.append(float(row["dvN_before_mps"]))
            ea.append(float(row["dvE_after_mps"]))
            na.append(float(row["dvN_after_mps"]))
    return (np.array(t), np.array(phase), np.array(eb), np.array(nb), np.array(ea),
            np.array(na))


def phase_spans(t, mask):
    """(start, end) times of the runs of consecutive True in `mask`, each reaching halfway to
    the neighbouring epochs (what step="mid" shading showed)."""
    spans = []
    n = len(t)
    i = 0
    while i < n:
        if not mask[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and mask[j + 1]:
            j += 1
        start = 0.5 * (t[i - 1] + t[i]) if i > 0 else t[i]
        end = 0.5 * (t[j] + t[j + 1]) if j + 1 < n else t[j]
        spans.append((start, end))
        i = j + 1
    return spans


def residuals_figure(report, series):
    """The residuals figure. Phase shading is drawn with axvspan, which spans the axis height
    without entering the y data limits: the residual axes follow the data (a fill_between
    over 0..1 with an axis transform counted 1.0 as data and forced every axis up to 1 m/s)."""
    t, phase, eb, nb, ea, na = series
    fig, axes = plt.subplots(3, 1, figsize=(11, 8), sharex=True)
    colours = {"turn": "#f4d6a0", "speed change": "#c9e4c5", "climb/descent": "#cfd8f0",
               "slow": "#dddddd"}
    for ax in axes:
        for name, colour in colours.items():
            for k, (start, end) in enumerate(phase_spans(t, phase == name)):
                ax.axvspan(start, end, color=colour, alpha=0.6, linewidth=0,
                           label=name if ax is axes[0] and k == 0 else None)
    axes[0].plot(t, eb, lw=0.7, label="dvE base fit")
    axes[0].plot(t, ea, lw=0.7, label="dvE final model")
    axes[0].set_ylabel("dvE (m/s)")
    axes[1].plot(t, nb, lw=0.7, label="dvN base fit")
    axes[1].plot(t, na, lw=0.7, label="dvN final model")
    axes[1].set_ylabel("dvN (m/s)")
    floor = report.get("noise_floor", {}).get("rms_mps")
    axes[2].plot(t, np.hypot(eb, nb), lw=0.7, label="|dv| base fit")
    axes[2].plot(t, np.hypot(ea, na), lw=0.7, label="|dv| final model")
    if floor:
        axes[2].axhline(floor, color="k", ls="--", lw=0.8, label="noise-floor RMS")
    axes[2].set_ylabel("|dv| (m/s)")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.legend(loc="upper left", fontsize=7, ncol=3)
        ax.grid(alpha=0.3)
    found = ", ".join(f["effect"] for f in report.get("found", [])) or "nothing"
    axes[0].set_title(f"INS-minus-GNSS velocity residuals (found: {found})")
    fig.tight_layout()
    return fig


def plot_residuals(report, series, out):
    fig = residuals_figure(report, series)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_phases(report, out):
    phases = report.get("phases", [])
    names = [p["phase"] for p in phases]
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(x - 0.27, [p["rms_before_mps"] for p in phases], 0.27, label="base fit")
    ax.bar(x, [p["rms_after_mps"] for p in phases], 0.27, label="final model")
    ax.bar(x + 0.27, [p["rms_floor_mps"] for p in phases], 0.27, label="noise floor")
    ax.set_xticks(x)
    ax.set_xticklabels([f"{n}\n({p['epochs']} epochs)" for n, p in zip(names, phases)],
                       fontsize=8)
    ax.set_ylabel("horizontal RMS (m/s)")
    ax.set_title("Residual RMS per flight phase")
    ax.legend()
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_scores(report, out):
    its = report.get("iterations", [])
    n = max(len(its), 1)
    fig, axes = plt.subplots(n, 1, figsize=(11, 3.2 * n), squeeze=False)
    for ax, it in zip(axes[:, 0], its):
        cands = it["candidates"]
        names = [c["effect"] for c in cands]
        z = [abs(c["z"]) if c["z"] is not None else 0.0 for c in cands]
        colours = ["tab:red" if c["significant"] else
                   ("tab:gray" if not c["observable"] else "tab:blue") for c in cands]
        ax.bar(range(len(names)), z, color=colours)
        ax.axhline(it["threshold_z"], color="k", ls="--", lw=0.8,
                   label=f"family-wise 5 % threshold |z| = {it['threshold_z']:.2f}")
        ax.set_yscale("log")
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names, rotation=70, fontsize=7)
        ax.set_ylabel("|z|")
        choice = it.get("choice") or "none"
        ax.set_title(f"iteration {it['iteration']}: candidate scores (choice: {choice}; "
                     "red significant, grey not observable)", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--report", required=True)
    ap.add_argument("--series", required=True)
    ap.add_argument("--prefix", required=True)
    a = ap.parse_args(argv)
    with open(a.report) as f:
        report = json.load(f)
    series = load_series(a.series)
    plot_residuals(report, series, a.prefix + "_residuals.png")
    plot_phases(report, a.prefix + "_phases.png")
    plot_scores(report, a.prefix + "_scores.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
