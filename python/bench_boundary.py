#!/usr/bin/env python3
"""What the Python boundary costs (issue 48): insid.Problem.evaluate on a batch against the C++
batch call inside it, paired in one run (Problem._evaluate_timed times the C++ call alone).

    PYTHONPATH=build/python /usr/bin/python3 python/bench_boundary.py [--preset paper]
        [--batch 32] [--repetitions 15] [--threads 0]

Prints the medians: the whole Python call, the C++ call inside it, their difference and its
fraction of the C++ call; and a single candidate's call the same way.
"""
import argparse
import statistics
import time

import numpy as np

import insid


def measure(p, X, repetitions):
    whole, inner = [], []
    for _ in range(repetitions):
        t0 = time.perf_counter()
        _, cxx = p._evaluate_timed(X)
        whole.append(time.perf_counter() - t0)
        inner.append(cxx)
    return statistics.median(whole), statistics.median(inner)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="paper")
    ap.add_argument("--flight-s", type=float, default=None)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--repetitions", type=int, default=15)
    ap.add_argument("--threads", type=int, default=0)
    a = ap.parse_args()
    p = insid.Problem(preset=a.preset, flight_s=a.flight_s, threads=a.threads)
    X = np.random.default_rng(1).uniform(-1, 1, size=(a.batch, p.dimension))
    for label, batch in ((f"batch of {a.batch}", X), ("one candidate", X[:1])):
        whole, inner = measure(p, batch, a.repetitions)
        print(f"{a.preset}, {label}: Python call {whole * 1e3:.3f} ms, C++ call {inner * 1e3:.3f} ms,"
              f" boundary {(whole - inner) * 1e6:.1f} us = {100 * (whole - inner) / inner:.3f} %"
              f" (medians of {a.repetitions})")


if __name__ == "__main__":
    main()
