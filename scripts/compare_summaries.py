#!/usr/bin/env python3
"""Compare two campaign summary.json files value by value to N significant digits.

Usage: compare_summaries.py OLD NEW [--digits 6]
Prints every numeric value (or string/bool) that differs, with its JSON path; wall times and
the build block are reported apart (they are expected to differ). Exit 0 when all other values
agree to the digits asked for, 1 otherwise. OLD and NEW may be xz-compressed (.xz); a committed
summary.json packed by scripts/pack_results.py is read whole from its
summary.full.json.xz beside it.
"""
import argparse
import math
import re
import sys

from pack_results import load_packed

EXPECTED = re.compile(r"wall|seconds|_s$|elapsed|build|timestamp|created|git_revision|hostname")


def leaves(x, path=""):
    if isinstance(x, dict):
        for k, v in x.items():
            yield from leaves(v, f"{path}/{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from leaves(v, f"{path}[{i}]")
    else:
        yield path, x


def agree(a, b, digits):
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) \
            or not isinstance(b, (int, float)):
        return a == b
    if a == b:
        return True
    if math.isnan(a) and math.isnan(b):
        return True
    return f"{a:.{digits - 1}e}" == f"{b:.{digits - 1}e}"


def load(path):
    return load_packed(path, lambda msg: print(f"compare_summaries: {msg}", file=sys.stderr))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--digits", type=int, default=6)
    args = ap.parse_args()
    old = dict(leaves(load(args.old)))
    new = dict(leaves(load(args.new)))
    differ, expected, identical, total = [], [], 0, 0
    for path in sorted(set(old) | set(new)):
        if path not in old or path not in new:
            differ.append((path, old.get(path, "<absent>"), new.get(path, "<absent>")))
            continue
        total += 1
        a, b = old[path], new[path]
        if a == b:
            identical += 1
            continue
        if EXPECTED.search(path):
            expected.append((path, a, b))
        elif not agree(a, b, args.digits):
            differ.append((path, a, b))
    print(f"{total} values: {identical} identical, {len(expected)} wall-time/build values differ, "
          f"{len(differ)} others differ beyond {args.digits} significant digits")
    for path, a, b in differ:
        rel = ""
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and a:
            rel = f"  (relative {abs(b - a) / abs(a):.2e})"
        print(f"  {path}: {a!r} -> {b!r}{rel}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
