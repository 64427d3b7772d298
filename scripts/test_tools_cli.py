#!/usr/bin/env python3
"""The research programs' command lines (tools/): `--help` exits 0 and names every
option the program has had (scripts and results/*/README.md call them by these names); a bad
option value, an unknown option and a bad name read later (a preset, an algorithm) each exit 2
before any work, with 'PROGRAM: error: ...' naming the option on stderr, like `insid` (README
"exit codes").

Usage: test_tools_cli.py PROGRAM     (exit 0 = pass; ctest `tools_cli.<program>`)
Each case runs in an empty temporary directory with a timeout, so a case the program wrongly
accepts cannot write into the source tree or run for long.
"""
import os
import subprocess
import sys
import tempfile

# program -> (its options, [(bad arguments, the option the error must name)])
PROGRAMS = {
    "insid-window-study": (
        ["--grades", "--windows", "--seeds", "--flight-s", "--threads", "--set-up", "--csv"],
        [
            (["--seeds", "x"], "--seeds"),
            (["--seeds", "0"], "--seeds"),
            (["--windows", "10,nan"], "--windows"),
            (["--flight-s", "inf"], "--flight-s"),
            (["--threads", "-1"], "--threads"),
            (["--set-up", "sideways"], "--set-up"),
            (["--grades", "mems,tactical"], "--grades"),
        ],
    ),
    "insid-uncertainty-study": (
        ["--preset", "--flight-s", "--grade", "--seeds", "--replicas", "--evaluations", "--algo",
         "--jsonl"],
        [
            (["--seeds", "0"], "--seeds"),
            (["--replicas", "x"], "--replicas"),
            (["--preset", "nowhere"], "--preset"),
            (["--grade", "tactical"], "--grade"),
            (["--algo", "lm", "no-such-algorithm"], "--algo"),
        ],
    ),
    "insid-mems-study": (
        ["--seeds", "--flight-s", "--align-s", "--window-s", "--replicas", "--threads",
         "--ekf-passes", "--ekf-update-interval-s", "--ekf-attitude",
         "--ekf-propagation-interval-s", "--ekf-use-position", "--sd-scale", "--swarm",
         "--swarm-evaluations", "--swarm-seed", "--methods", "--ekf-only", "--heading-check",
         "--csv", "--flight", "--drone-arw-deg-rth", "--drone-vrw-mps-rth",
         "--drone-gnss-vel-sigma-mps", "--drone-gnss-pos-sigma-m", "--truth-max-sigma",
         "--box-sigma", "--noise-in-meta", "--ekf-param", "--json"],
        [
            (["--seeds", "0"], "--seeds"),
            (["--flight", "plane"], "--flight"),
            (["--flight", "drone", "--box-sigma", "0"], "--box-sigma"),
            (["--flight", "drone", "--drone-arw-deg-rth", "-1"], "--drone-arw-deg-rth"),
            (["--ekf-param", "arw_deg_rth=x"], "--ekf-param"),
            (["--ekf-param", "no_such_key=1"], "--ekf-param"),
            (["--flight-s", "x"], "--flight-s"),
            (["--methods", "ekf-rts", "guess"], "--methods"),
            (["--swarm", "no-such-algorithm"], "--swarm"),
            (["--ekf-attitude", "upside-down"], "--ekf-attitude"),
        ],
    ),
    "insid-diagnose-campaign": (
        ["--out-dir", "--flight-s", "--seeds", "--null-seeds", "--sizes", "--threads",
         "--iterations", "--replicas-basis", "--replicas-calibration", "--family-calibration",
         "--summary-only", "--matrix", "--null-flights", "--null-presets", "--presets",
         "--windows"],
        [
            (["--seeds", "x", "--summary-only"], "--seeds"),
            (["--matrix", "huge", "--summary-only"], "--matrix"),
            (["--sizes", "1,y", "--summary-only"], "--sizes"),
        ],
    ),
    "insid-paper-table": (
        ["--out", "--preset", "--config", "--alignment", "--grade", "--flight-s", "--seed",
         "--series-rate-hz", "--timing-repeats"],
        [
            (["--timing-repeats", "x"], "--timing-repeats"),
            (["--alignment", "sideways"], "--alignment"),
            (["--preset", "nowhere"], "--preset"),
            (["--grade", "tactical"], "--grade"),
        ],
    ),
    "insid-kernel-budget": (
        ["--presets", "--grades", "--flight-s", "--mems-window-s", "--candidates", "--seed",
         "--threads", "--out", "--force"],
        [
            (["--presets", "paper,nowhere"], "--presets"),
            (["--grades", "tactical"], "--grades"),
            (["--flight-s", "nan"], "--flight-s"),
            (["--candidates", "1"], "--candidates"),
            (["--threads", "0"], "--threads"),
        ],
    ),
    "insid-fitness-surrogate-study": (
        ["--data", "--preset", "--flight-s", "--grade", "--window-s", "--initial-attitude",
         "--estimate", "--candidates", "--near", "--floor", "--step", "--seed", "--threads",
         "--jsonl"],
        [
            (["--preset", "nowhere"], "--preset"),
            (["--grade", "consumer"], "--grade"),
            (["--window-s", "nan"], "--window-s"),
            (["--candidates", "0"], "--candidates"),
            (["--step", "0"], "--step"),
            (["--estimate", "gyro_bias_q"], "--estimate"),
            (["--initial-attitude", "sideways"], "--initial-attitude"),
        ],
    ),
}


def run(program, args, cwd):
    return subprocess.run([program] + args, cwd=cwd, capture_output=True, text=True, timeout=60)


def main():
    program = os.path.abspath(sys.argv[1])
    name = os.path.basename(program)
    options, bad_cases = PROGRAMS[name]
    failures = []
    with tempfile.TemporaryDirectory() as cwd:
        r = run(program, ["--help"], cwd)
        if r.returncode != 0:
            failures.append(f"--help: exit {r.returncode}, expected 0; stderr: {r.stderr.strip()}")
        missing = [o for o in options if o not in r.stdout]
        if missing:
            failures.append(f"--help does not name {missing}")
        if "Exit codes" not in r.stdout:
            failures.append("--help does not state the exit codes")
        cases = bad_cases + [(["--no-such-option", "1"], "--no-such-option")]
        for args, option in cases:
            r = run(program, args, cwd)
            line = r.stderr.strip().splitlines()[0] if r.stderr.strip() else ""
            if r.returncode != 2:
                failures.append(f"{' '.join(args)}: exit {r.returncode}, expected 2; "
                                f"stderr: {r.stderr.strip()[:300]}")
            elif not line.startswith(name + ": error: ") or option not in line:
                failures.append(f"{' '.join(args)}: the error does not name {option} after "
                                f"'{name}: error: ': {line}")
            if os.listdir(cwd):
                failures.append(f"{' '.join(args)}: wrote {os.listdir(cwd)} before refusing")
                break
    for f in failures:
        print(f"FAIL {name} {f}")
    if not failures:
        print(f"{name}: --help and {len(bad_cases) + 1} refused command lines as expected")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
