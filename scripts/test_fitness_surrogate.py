#!/usr/bin/env python3
"""The fitness surrogate study's figures hold together on a short navigation-grade flight
(ctest `fitness_surrogate`): the second-order Taylor model of the residuals agrees with the exact
Eq. 15 to 1e-4 over the box (issue 47's criterion 1 at navigation grade) and far better than the
first-order one, the model taken at the optimum agrees near it, and the exact kernel's floor sits
below all of them. A dropped second-order term, a wrong Jacobian or a model taken elsewhere fails.

Usage: test_fitness_surrogate.py PROGRAM
"""
import json
import os
import subprocess
import sys
import tempfile


def main():
    program = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "s.jsonl")
        subprocess.run([program, "--preset", "rich", "--flight-s", "200", "--candidates", "60",
                        "--near", "10", "--floor", "2", "--threads", "2", "--jsonl", out],
                       check=True, cwd=tmp, timeout=600, stdout=subprocess.DEVNULL)
        with open(out) as f:
            j = json.loads(f.readline())
    print(json.dumps(j, indent=1))
    ok = True

    def expect(cond, what):
        nonlocal ok
        if not cond:
            print("FAIL:", what)
            ok = False

    expect(j["max_rel_diff_second_order_box"] <= 1e-4, "second order within 1e-4 over the box")
    expect(j["max_rel_diff_second_order_box"] * 10 < j["max_rel_diff_first_order_box"],
           "second order ten times closer than first order over the box")
    expect(j["max_rel_diff_second_order_near_model_at_optimum"] <= 1e-6,
           "the model at the optimum within 1e-6 near it")
    expect(j["kernel_floor_vs_scalar"] < j["max_rel_diff_second_order_near_model_at_optimum"],
           "the exact kernel's floor below the model's difference")
    expect(j["exact_runs_to_build"] == 1 + 2 * 4 + 6, "1 + 2d + d(d - 1)/2 exact runs for d = 4")
    # The fast search fitness itself (identification/search_fitness.h: the model at the centre,
    # its x-dependent part interpolated between nodes): as close as the model it interpolates.
    expect(j["max_rel_diff_fast_box"] <= 1e-4, "the fast search fitness within 1e-4 over the box")
    expect(j["max_rel_diff_fast_near"] <= 1e-4, "the fast search fitness within 1e-4 near the optimum")
    expect(j["max_rel_diff_fast_box"] > 0, "the fast search fitness is not the exact kernel")
    expect(j["fast_fitness"]["check_max_relative_difference"] <= 1e-4, "its own check passes")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
