#!/usr/bin/env python3
"""Kernel speed of the CPU paths in one run: Google Benchmark `insid-microbench` of each build,
run interleaved (native, avx512, avx2, baseline, then again) so that the machine's load falls on
every path alike; prints the median ns per candidate-step per benchmark and the ratios to the
first binary (results/perf/README.md, "CPU dispatch").

Usage: cpu_paths_bench.py [--rounds R] [--filter REGEX] NAME=MICROBENCH ...
"""
import argparse
import json
import statistics
import subprocess
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--filter", default="BM_FitnessScalar|BM_FitnessBatched/K:(8|16|32)/threads:1/")
    ap.add_argument("binaries", nargs="+", help="NAME=path of an insid-microbench")
    args = ap.parse_args()
    bins = [b.split("=", 1) for b in args.binaries]
    times = {}  # (benchmark, name) -> [ns per candidate-step]
    order = []
    for r in range(args.rounds):
        for name, path in bins:
            out = subprocess.run([path, f"--benchmark_filter={args.filter}", "--benchmark_format=json"],
                                 capture_output=True, text=True, check=True).stdout
            for b in json.loads(out)["benchmarks"]:
                key = b["name"]
                if key not in order:
                    order.append(key)
                times.setdefault((key, name), []).append(b["ns_per_candidate_step"])
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    names = [n for n, _ in bins]
    print("| benchmark | " + " | ".join(f"{n} ns" for n in names) + " | " +
          " | ".join(f"{n} / {names[0]}" for n in names[1:]) + " |")
    print("|---" * (2 * len(names)) + "|")
    for key in order:
        med = [statistics.median(times[(key, n)]) for n in names]
        short = key.split("/min_time")[0]
        print(f"| `{short}` | " + " | ".join(f"{m:.2f}" for m in med) + " | " +
              " | ".join(f"{m / med[0]:.3f}" for m in med[1:]) + " |")


if __name__ == "__main__":
    main()
