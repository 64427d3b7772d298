#!/usr/bin/python3
"""Null flights of this campaign judged by both family-wise rules (replica-max and gaussian).

Each case stores its first diagnose iteration whole (every candidate's row, both thresholds, the
calibration replicas' own max |z|), so the first naming decision can be re-judged under either
rule: a null flight is a false alarm when some candidate is significant at iteration 1
(normal-equivalent |z| above the rule's threshold, and observable: minimum detectable size
(threshold + 1.645) sd <= 30 catalogue sigmas, as diagnose decides it).
Also checks the Gaussian re-judgment against ../issue15 (same seeds, run with the Gaussian rule),
read beside the given file (issue15/cases.jsonl or its .xz).
Usage: /usr/bin/python3 scripts/diagnose_rejudge.py [CASES] > results/diagnose/issue15-wy/rejudge.json
  CASES: a cases.jsonl, plain or xz-compressed (default results/diagnose/issue15-wy/cases.jsonl.xz,
  as committed)
"""
import json
import lzma
import math
import os
import sys
from collections import defaultdict
from scipy.stats import norm

Z_POWER = 1.6448536269514722
OBSERVABLE_MAX_SIGMA = 30.0


def wilson(k, n, z=1.959963984540054):
    if n == 0:
        return [0.0, 1.0]
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return [c - h, c + h]


def significant(case, threshold, observable_only=True):
    names = []
    for row in case["first_candidates"]:
        p = row["p_value"]
        z_normal = norm.isf(p / 2) if p is not None and p > 0 else 40.0
        observable = (threshold + Z_POWER) * row["sd_sigma"] <= OBSERVABLE_MAX_SIGMA
        if (observable == observable_only) and z_normal > threshold:
            names.append([row["effect"], round(row["z"], 3)])
    return names


def read_cases(path):
    """The cases of a cases.jsonl, plain or .xz; PATH itself, else PATH.xz, else PATH without .xz."""
    for p in (path, path + ".xz", path[:-3] if path.endswith(".xz") else None):
        if p and os.path.exists(p):
            with (lzma.open(p, "rt") if p.endswith(".xz") else open(p)) as f:
                return [json.loads(line) for line in f if line.strip()]
    raise FileNotFoundError(path)


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "results/diagnose/issue15-wy/cases.jsonl.xz"
    cases = read_cases(path)
    old_path = os.path.join(os.path.dirname(os.path.abspath(path)), "..", "issue15", "cases.jsonl")
    nulls = [c for c in cases if c["kind"] == "null"]
    out = {"null_flights": len(nulls), "rules": {}}
    for rule, key in (("replica-max", "threshold_z_replica_max"), ("gaussian", "threshold_z_gaussian")):
        fa = []
        by = defaultdict(lambda: [0, 0])
        for c in nulls:
            names = significant(c, c[key])
            g = f"{c['preset']} {int(c['flight_s'])} s"
            by[g][0] += 1
            if names:
                by[g][1] += 1
                fa.append({"key": c["key"], "significant": names, "threshold": c[key]})
        k = len(fa)
        unobs = sum(bool(significant(c, c[key], observable_only=False)) for c in nulls)
        out["rules"][rule] = {
            "flights_with_an_unobservable_candidate_above_threshold": unobs,
            "false_alarms": k,
            "rate": k / len(nulls) if nulls else None,
            "wilson95": wilson(k, len(nulls)),
            "by_preset_length": {g: {"flights": v[0], "false_alarms": v[1]} for g, v in sorted(by.items())},
            "cases": fa,
            "threshold_range": [min(c[key] for c in nulls), max(c[key] for c in nulls)] if nulls else None,
        }
    # The rule in use must agree with what the campaign recorded (found non-empty).
    used = [c for c in nulls if c.get("family_calibration") == "replica-max"]
    out["check_replica_max_matches_found"] = all(
        bool(significant(c, c["threshold_z_replica_max"])) == bool(c["found"]) for c in used)
    # The Gaussian re-judgment against the old campaign (Gaussian rule, same seeds).
    try:
        old = {c["key"]: c for c in read_cases(old_path)}
        same = [c for c in nulls if c["key"] in old]
        out["check_gaussian_matches_issue15"] = {
            "common_null_flights": len(same),
            "agree": sum(bool(significant(c, c["threshold_z_gaussian"])) == bool(old[c["key"]]["found"]) for c in same),
            "threshold_equal": sum(c["threshold_z_gaussian"] == old[c["key"]]["threshold_z"] for c in same)}
    except FileNotFoundError:
        pass
    # Effect cases: the first named effect (rule in use) and its ambiguity set; the same case of
    # ../issue15 (Gaussian rule) where it exists.
    try:
        old = {c["key"]: c for c in read_cases(old_path)}
    except FileNotFoundError:
        old = {}
    eff = []
    for c in cases:
        if c["kind"] != "single":
            continue
        truth = next(iter(c["hidden"]))
        first = c["found"][0] if c["found"] else None
        row = {"key": c["key"], "hidden": truth,
               "named_first": first["effect"] if first else None,
               "ambiguous_with": first["ambiguous_with"] if first else [],
               "truth_in_first_set": bool(first) and (first["effect"] == truth or truth in first["ambiguous_with"])}
        if c["key"] in old:
            of = old[c["key"]]["found"]
            row["gaussian_issue15_named_first"] = of[0]["effect"] if of else None
            row["same_first_as_issue15"] = row["named_first"] == row["gaussian_issue15_named_first"]
            row["same_found_as_issue15"] = (
                [(f["effect"], sorted(f["ambiguous_with"])) for f in c["found"]] ==
                [(f["effect"], sorted(f["ambiguous_with"])) for f in of])
        eff.append(row)
    out["effects"] = {"cases": len(eff),
                      "truth_in_first_set": sum(r["truth_in_first_set"] for r in eff),
                      "nothing_named": sum(r["named_first"] is None for r in eff),
                      "wrong_first_set": sum(r["named_first"] is not None and not r["truth_in_first_set"] for r in eff),
                      "compared_with_issue15": sum("same_first_as_issue15" in r for r in eff),
                      "same_first_as_issue15": sum(r.get("same_first_as_issue15", False) for r in eff),
                      "same_found_list_as_issue15": sum(r.get("same_found_as_issue15", False) for r in eff),
                      "rows": eff}
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
