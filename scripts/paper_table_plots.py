#!/usr/bin/python3
"""Figures 3-8 of the paper (velocity error of pure-INS navigation, Sec. 3.1) from the output of
insid-paper-table (results/paper-table/velocity_error_<case>.csv and table.json).

Usage: /usr/bin/python3 scripts/paper_table_plots.py [DIR]   (default results/paper-table)
Writes DIR/fig<N>_<case>.png and DIR/figs_all.png. Uses Debian's python3-matplotlib/numpy.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main() -> int:
    out = sys.argv[1] if len(sys.argv) > 1 else "results/paper-table"
    with open(os.path.join(out, "table.json")) as f:
        table = json.load(f)
    cases = table["cases"]
    fig_all, axes = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    for i, case in enumerate(cases):
        data = np.genfromtxt(os.path.join(out, f"velocity_error_{case['id']}.csv"),
                             delimiter=",", names=True)
        t_min = (data["t_s"] - data["t_s"][0]) / 60.0
        title = (f"{case['figure']}: {case['label']}\nEq. 15 fitness {case['fitness_eq15']:.4g} "
                 f"(paper {case['paper_fitness']:.4g}, ratio {case['ratio_to_paper']:.2f})")
        for ax in (None, axes.flat[i]):
            own = ax is None
            if own:
                fig, ax = plt.subplots(figsize=(8, 4.5))
            ax.plot(t_min, data["dvE_mps"], lw=0.8, label="east velocity error")
            ax.plot(t_min, data["dvN_mps"], lw=0.8, label="north velocity error")
            ax.set_ylabel("INS - GNSS velocity (m/s)")
            ax.set_title(title, fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="upper left")
            if own:
                ax.set_xlabel("time since navigation start (min)")
                fig.tight_layout()
                num = case["figure"].split()[-1]
                fig.savefig(os.path.join(out, f"fig{num}_{case['id']}.png"), dpi=110)
                plt.close(fig)
    for ax in axes[-1]:
        ax.set_xlabel("time since navigation start (min)")
    fig_all.suptitle(f"Paper Sec. 3.1 on the '{table['preset']}' preset "
                     f"({table['flight_s']:.0f} s flight, GNSS {table['gnss_rate_hz']:.0f} Hz, "
                     f"alignment {table['alignment']})")
    fig_all.tight_layout()
    fig_all.savefig(os.path.join(out, "figs_all.png"), dpi=90)
    return 0


if __name__ == "__main__":
    sys.exit(main())
