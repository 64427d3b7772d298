#!/usr/bin/env python3
"""insid-kernel-budget on short flights (ctest `kernel_budget`): the figures it
writes hold together. The floor is far below the tolerances; the sensitivities are linear (the
change doubles at twice the error); the first-order body rotation's leftover is tiny at
navigation grade and orders of magnitude larger at MEMS grade (gyro biases ~3.6e4 x larger:
the leftover grows with their square), as results/perf/fewer-ops/README.md reports.

Usage: test_kernel_budget.py PROGRAM   (exit 0 = pass)
"""
import json
import os
import subprocess
import sys
import tempfile


def main():
    program = sys.argv[1]
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([program, "--presets", "rich", "--flight-s", "120", "--candidates", "3",
                        "--out", out], check=True, capture_output=True, timeout=300)
        cases = {c["grade"]: c for c in json.load(open(os.path.join(out, "budget.json")))["cases"]}
    failures = []
    for grade, tolerance in (("nav", 1e-7), ("mems", 1e-5)):
        c = cases[grade]
        if c["tolerance_relative"] != tolerance:
            failures.append(f"{grade}: tolerance {c['tolerance_relative']}")
        if not c["floor"]["baseline_vs_scalar"] < 1e-9:
            failures.append(f"{grade}: unfused path vs scalar {c['floor']['baseline_vs_scalar']}")
        for key in ("change_ratio_at_twice_the_rate_error", "change_ratio_at_twice_the_force_error"):
            if abs(c[key] - 2.0) > 0.01:
                failures.append(f"{grade}: {key} = {c[key]} (linear: 2)")
        for key in ("budget_rate_error_rad_per_step", "budget_force_error_mps_per_step"):
            if not 0.0 < c[key] < 1e-3:
                failures.append(f"{grade}: {key} = {c[key]}")
    nav = cases["nav"]["first_order_body_rotation_leftover"][0]["largest_rad_per_interval"]
    mems = cases["mems"]["first_order_body_rotation_leftover"][0]["largest_rad_per_interval"]
    if not 0.0 <= nav < 1e-15:
        failures.append(f"nav body-rotation leftover {nav} rad (expected < 1e-15)")
    if not mems > 1e6 * max(nav, 1e-20):
        failures.append(f"mems body-rotation leftover {mems} rad not >> nav {nav}")
    if failures:
        print("insid-kernel-budget:\n  " + "\n  ".join(failures))
        return 1
    print(f"insid-kernel-budget: consistent (body rotation leftover nav {nav:.2e}, mems {mems:.2e} rad)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
