#!/usr/bin/env python3
"""Navigation error against time, before and after compensation, from two `insid navigate`
solutions of the same dataset.

usage: nav_error_plot.py --data DATASET_DIR --before NAV.csv --after NAV.csv --out FIGURE.png
       [--label-before TEXT] [--label-after TEXT]

The reference is the dataset's truth.csv when it has one (simulated data: the error is
INS minus truth), else its gnss.csv (measured data: INS minus GNSS, which includes the GNSS
noise). The solutions are interpolated linearly to the reference epochs inside their span.
Position errors are north/east distances on the WGS-84 ellipsoid (m), velocity errors the
horizontal norm (m/s). Typical use:

  insid navigate --data D --out before.csv --summary before.json
  insid identify --data D --out result.json
  insid navigate --data D --compensate-from result.json --out after.csv --summary after.json
  /usr/bin/python3 scripts/nav_error_plot.py --data D --before before.csv --after after.csv \\
      --out nav_error.png

(Debian's python3-matplotlib / numpy only.)
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

WGS84_A_M = 6378137.0
WGS84_E2 = 6.69437999014e-3
COLUMNS = ("t_s", "lat_deg", "lon_deg", "h_m", "vE_mps", "vN_mps")


def read_solution(path):
    """{column: array} of a navigate CSV, truth.csv or gnss.csv (t_s, lat/lon/h, vE/vN)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no data rows")
    missing = [c for c in COLUMNS if c not in rows[0]]
    if missing:
        raise ValueError(f"{path}: missing column(s) {', '.join(missing)} (expected the "
                         f"columns of insid navigate --out: {', '.join(COLUMNS)}, ...)")
    out = {}
    for c in COLUMNS:
        try:
            out[c] = np.array([float(r[c]) for r in rows])
        except ValueError as e:
            raise ValueError(f"{path}: column {c}: {e}") from None
    if np.any(np.diff(out["t_s"]) <= 0):
        raise ValueError(f"{path}: t_s is not increasing")
    return out


def reference(data_dir):
    """(solution, name): truth.csv when present, else gnss.csv."""
    truth = os.path.join(data_dir, "truth.csv")
    if os.path.exists(truth):
        return read_solution(truth), "truth"
    return read_solution(os.path.join(data_dir, "gnss.csv")), "GNSS"


def errors(nav, ref):
    """(t_s, horizontal position error m, horizontal velocity error m/s) at the reference
    epochs inside the solution's span."""
    t0, t1 = nav["t_s"][0], nav["t_s"][-1]
    inside = (ref["t_s"] >= t0 - 1e-9) & (ref["t_s"] <= t1 + 1e-9)
    if not inside.any():
        raise ValueError("the solution and the reference do not overlap in time")
    t = ref["t_s"][inside]
    at = {c: np.interp(t, nav["t_s"], nav[c]) for c in COLUMNS[1:]}
    lat = np.radians(ref["lat_deg"][inside])
    h = ref["h_m"][inside]
    s2 = np.sin(lat) ** 2
    r_meridian = WGS84_A_M * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5
    r_normal = WGS84_A_M / np.sqrt(1 - WGS84_E2 * s2)
    d_north = np.radians(at["lat_deg"] - ref["lat_deg"][inside]) * (r_meridian + h)
    d_east = np.radians(at["lon_deg"] - ref["lon_deg"][inside]) * (r_normal + h) * np.cos(lat)
    dv = np.hypot(at["vE_mps"] - ref["vE_mps"][inside], at["vN_mps"] - ref["vN_mps"][inside])
    return t, np.hypot(d_north, d_east), dv


def figure(ref_name, before, after, label_before, label_after):
    """The two-panel figure; `before`/`after` are errors() tuples."""
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True)
    for (t, dp, dv), label, colour in ((before, label_before, "tab:red"),
                                       (after, label_after, "tab:blue")):
        axes[0].plot(t, dp, lw=1.0, color=colour,
                     label=f"{label}: final {dp[-1]:.3g} m, max {dp.max():.3g} m")
        axes[1].plot(t, dv, lw=0.8, color=colour,
                     label=f"{label}: RMS {np.sqrt(np.mean(dv ** 2)):.3g} m/s, "
                           f"max {dv.max():.3g} m/s")
    axes[0].set_ylabel("horizontal position error (m)")
    axes[1].set_ylabel("horizontal velocity error (m/s)")
    axes[1].set_xlabel("time (s)")
    for ax in axes:
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    axes[0].set_title(f"Pure-INS navigation error (INS minus {ref_name}), before and after "
                      "compensation")
    fig.tight_layout()
    return fig


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="dataset directory (truth.csv or gnss.csv)")
    ap.add_argument("--before", required=True, help="navigate --out CSV without compensation")
    ap.add_argument("--after", required=True, help="navigate --out CSV with compensation")
    ap.add_argument("--out", required=True, help="figure PNG")
    ap.add_argument("--label-before", default="before (no compensation)")
    ap.add_argument("--label-after", default="after (compensated)")
    a = ap.parse_args(argv)
    try:
        ref, ref_name = reference(a.data)
        before = errors(read_solution(a.before), ref)
        after = errors(read_solution(a.after), ref)
    except (OSError, ValueError) as e:
        print(f"nav_error_plot.py: error: {e}", file=sys.stderr)
        return 1
    fig = figure(ref_name, before, after, a.label_before, a.label_after)
    fig.savefig(a.out, dpi=110)
    plt.close(fig)
    print(f"nav_error_plot.py: wrote {a.out} (INS minus {ref_name}; final position error "
          f"{before[1][-1]:.3g} m before, {after[1][-1]:.3g} m after)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
