#!/usr/bin/env python3
"""Figures and tables of the `insid diagnose` hidden-effect campaign.

usage: diagnose_campaign_report.py [RESULTS_DIR]   (default results/diagnose)
reads RESULTS_DIR/cases.jsonl (or, where that is absent, cases.jsonl.xz, the form committed under
results/) and summary.json (written by insid-diagnose-campaign), writes
RESULTS_DIR/confusion.png, power.png, shrink.png and tables.md.
"""
import collections
import json
import lzma
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402


def in_class(f, name):
    return f["effect"] == name or name in f.get("ambiguous_with", [])


def main(argv):
    d = argv[0] if argv else "results/diagnose"
    path = os.path.join(d, "cases.jsonl")
    if not os.path.exists(path) and os.path.exists(path + ".xz"):
        path += ".xz"
    with (lzma.open(path, "rt") if path.endswith(".xz") else open(path)) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    summary = json.load(open(os.path.join(d, "summary.json")))
    nominal = summary["nominal"]

    # Confusion matrix at the nominal size (+ effect-free rich seeds): hidden -> first named.
    hidden_names = ["(none)"] + list(nominal.keys())
    conf = collections.defaultdict(collections.Counter)
    for r in rows:
        if r["kind"] == "null" and r["preset"] == "rich":
            conf["(none)"][r["found"][0]["effect"] if r["found"] else "(none)"] += 1
        elif r["kind"] == "single" and r["size_factor"] == 1.0:
            h = next(iter(r["hidden"]))
            conf[h][r["found"][0]["effect"] if r["found"] else "(none)"] += 1
    named = ["(none)"] + list(nominal.keys())
    for h in conf:
        for n in conf[h]:
            if n not in named:
                named.append(n)
    m = np.array([[conf[h][n] for n in named] for h in hidden_names], dtype=float)
    fig, ax = plt.subplots(figsize=(1.0 + 0.75 * len(named), 1.2 + 0.55 * len(hidden_names)))
    ax.imshow(m, cmap="Blues")
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            if m[i, j]:
                ax.text(j, i, int(m[i, j]), ha="center", va="center", fontsize=8)
    ax.set_xticks(range(len(named)))
    ax.set_xticklabels(named, rotation=60, ha="right", fontsize=8)
    ax.set_yticks(range(len(hidden_names)))
    ax.set_yticklabels([h if h == "(none)" else f"{h} ({nominal[h]['label']})"
                        for h in hidden_names], fontsize=8)
    ax.set_xlabel("first effect named by insid diagnose")
    ax.set_ylabel("hidden effect (nominal size)")
    ax.set_title("Confusion matrix, rich preset, %g s flight" % summary["flight_s"], fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "confusion.png"), dpi=110)
    plt.close(fig)

    # Detection power vs size (named or collinear class).
    # Effects with equal fractions would hide one another: each line is drawn a little above the
    # previous one (at most +-0.04, said in the axis label); the sizes are the x ticks, in plain
    # numbers.
    fig, ax = plt.subplots(figsize=(8, 4.5))
    effects = list(summary["power"].items())
    sizes = set()
    for k, (h, pts) in enumerate(effects):
        pts = sorted(pts, key=lambda p: p["size_factor"])
        x = [p["size_factor"] for p in pts]
        sizes.update(x)
        offset = 0.08 * (k / max(len(effects) - 1, 1) - 0.5)
        y = [p["detected_class"] / p["n"] + offset for p in pts]
        ax.plot(x, y, "o-", label=f"{h} (1 = {nominal[h]['label']})")
    ax.set_xscale("log")
    ax.set_xticks(sorted(sizes))
    ax.set_xticklabels([f"{v:g}" for v in sorted(sizes)])
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_ylim(-0.1, 1.1)
    ax.set_xlabel("hidden size / nominal size")
    ax.set_ylabel("fraction named (or its collinear class);\nlines offset by up to +-0.04 to stay visible", fontsize=8)
    ax.axhline(summary["false_alarm"]["rate"], color="k", ls=":", lw=0.8,
               label="false-alarm rate (no hidden effect)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("Detection power, rich preset, %g s flight" % summary["flight_s"], fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "power.png"), dpi=110)
    plt.close(fig)

    # Tables.
    out = ["# insid diagnose campaign tables (generated)", ""]
    fa = summary["false_alarm"]
    out.append(f"False alarms: {fa['rich_with_found']} of {fa['rich_seeds']} effect-free rich "
               f"seeds ({100 * fa['rate']:.1f} %), {fa['straight_with_found']} of "
               f"{fa['straight_seeds']} straight seeds.")
    out.append("")
    out.append("| hidden effect | size factor | size (SI) | named or class | named exactly | n | "
               "median z of the hidden effect | median shrink |")
    out.append("|---|---|---|---|---|---|---|---|")
    by = collections.defaultdict(list)
    for r in rows:
        if r["kind"] == "single":
            by[(next(iter(r["hidden"])), r["size_factor"])].append(r)
    for (h, f), rs in sorted(by.items()):
        cls = sum(1 for r in rs if r["found"] and in_class(r["found"][0], h))
        exact = sum(1 for r in rs if r["found"] and r["found"][0]["effect"] == h)
        zs = [abs(r["hidden_rows"][h]["z"]) for r in rs if r.get("hidden_rows", {}).get(h)]
        sh = [r["gap"]["shrink"] for r in rs if isinstance(r["gap"].get("shrink"), (int, float))]
        out.append(f"| {h} | {f:g} | {f * nominal[h]['value']:.4g} | {cls} | {exact} | {len(rs)} | "
                   f"{np.median(zs) if zs else float('nan'):.1f} | "
                   f"{np.median(sh) if sh else float('nan'):.2f} |")
    out.append("")
    out.append("| case | hidden | found | not_observable contains it | shrink |")
    out.append("|---|---|---|---|---|")
    for r in rows:
        if r["kind"] in ("pair", "unobservable"):
            hid = ", ".join(f"{k}={v:g}" for k, v in r["hidden"].items())
            fnd = ", ".join(f["effect"] + (" (~" + "/".join(f["ambiguous_with"]) + ")"
                                           if f["ambiguous_with"] else "") for f in r["found"])
            no = all(k in r["not_observable"] for k in r["hidden"])
            sh = r["gap"].get("shrink")
            out.append(f"| {r['kind']} {r['preset']} seed {r['seed']} | {hid} | {fnd or '-'} | "
                       f"{no} | {sh if sh is None else round(sh, 2)} |")
    out.append("")
    walls = [r["wall_s"] for r in rows]
    out.append(f"{len(rows)} cases, {sum(walls) / 60:.1f} min in all, median "
               f"{np.median(walls):.1f} s per case (2 cores, shared machine).")
    open(os.path.join(d, "tables.md"), "w").write("\n".join(out) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
