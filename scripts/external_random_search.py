#!/usr/bin/env python3
"""Reference client of insid's external-optimizer protocol (optimizers/README.md): uniform
random search in the box, numpy only.

    insid identify --data DIR --algo "external:/usr/bin/python3 scripts/external_random_search.py"

Reads one JSON object per line on stdin, answers on stdout (one line, flushed); logs go to
stderr, never stdout. Points: numpy.random.default_rng(seed from the problem message), one
Generator.uniform(lower, upper, size=(batch, dimension)) draw per ask, `batch` = --batch
(default 10) or fewer when the remaining evaluation budget is smaller. The whole run's points are
therefore the first rows of default_rng(seed).uniform(lower, upper, size=(E, dimension)).
"""
import argparse
import json
import sys

import numpy as np


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=10, help="points per ask (default 10)")
    args = parser.parse_args()
    if args.batch < 1:
        parser.error("--batch must be >= 1")

    rng = lower = upper = None
    dimension = 0
    for line in sys.stdin:
        if not line.strip():
            continue
        message = json.loads(line)
        kind = message.get("type")
        if kind == "problem":
            if message.get("protocol") != 1:
                print(json.dumps({"error": "protocol %r not supported" % message.get("protocol")}),
                      flush=True)
                return 1
            dimension = int(message["dimension"])
            lower = np.asarray(message["lower"], dtype=float)
            upper = np.asarray(message["upper"], dtype=float)
            rng = np.random.default_rng(int(message["seed"]))
        elif kind == "ask":
            batch = args.batch
            remaining = message.get("remaining_evaluations")
            if remaining is not None:
                batch = max(1, min(batch, int(remaining)))
            points = rng.uniform(lower, upper, size=(batch, dimension))
            # json writes the shortest repr of each double: insid reads back the same bits.
            print(json.dumps({"points": points.tolist()}), flush=True)
        elif kind == "tell":
            pass  # random search ignores the fitness
        elif kind == "stop":
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
