#!/usr/bin/env python3
"""The CPU-dispatching `insid` (kernel/cpu_path.h): every kernel path this CPU runs gives the same
results within the batched kernel's tolerance, the same path gives the same bits for 1 and 2
threads, INSID_CPU selects the path (--version prints it), and a bad INSID_CPU is refused. A forced
path the CPU lacks is refused: on this CPU through INSID_CPU_HIDE (the test-only override, which
can only take paths away), on a CPU that lacks one for real as well.

Usage: test_cpu_paths.py PROGRAM     (exit 0 = pass; ctest `cpu_paths`)
"""
import json
import os
import subprocess
import sys
import tempfile

RTOL = 1e-9  # the batched-vs-scalar tolerance (tests/batch_fitness_test.cc)
# The fast search fitness (identification/search_fitness.h) steers identify's DVPIO: its loop gives
# the same bits on every path, but its model is built from exact runs by second differences with
# a step of 0.02 box units, which divide the paths' rounding differences (RTOL) by 0.02^2.
RTOL_FAST_SEARCH = RTOL / 0.02 ** 2


def cpu_levels():
    """Paths this CPU runs, from /proc/cpuinfo flags (independent of insid's own check)."""
    flags = set()
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("flags"):
                flags = set(line.split(":", 1)[1].split())
                break
    # LZCNT ("abm") is part of x86-64-v3 too, but some hypervisors leave the flag out of cpuinfo
    # (this machine's KVM guest) while the CPUID bit insid reads is set.
    v3 = {"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "movbe", "xsave"} <= flags
    v4 = v3 and {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"} <= flags
    return [p for p, ok in (("avx512", v4), ("avx2", v3), ("baseline", True)) if ok]


def run(insid, args, cpu=None, threads=None, check=True, hide=None):
    env = dict(os.environ)
    env.pop("INSID_CPU", None)
    env.pop("INSID_CPU_HIDE", None)
    if cpu is not None:
        env["INSID_CPU"] = cpu
    if hide is not None:
        env["INSID_CPU_HIDE"] = hide
    if threads is not None:
        env["OMP_NUM_THREADS"] = str(threads)
    return subprocess.run([insid] + args, env=env, capture_output=True, text=True, check=check)


def main():
    insid = sys.argv[1]
    failures = []
    paths = cpu_levels()
    work = tempfile.mkdtemp(prefix="insid-cpu-")
    data = os.path.join(work, "rich")
    run(insid, ["simulate", "--preset", "rich", "--flight-s", "120", "--out", data])

    # The automatic choice is the best path, and --version says which.
    v = run(insid, ["--version"]).stdout
    if f"CPU path:     {paths[0]} " not in v:
        failures.append(f"automatic choice: expected {paths[0]}, --version says:\n{v}")
    # A bad value is refused with the accepted values named.
    r = run(insid, ["--version"], cpu="avx1024", check=False)
    if r.returncode == 0 or "expected avx512, avx2 or baseline" not in r.stderr:
        failures.append(f"INSID_CPU=avx1024 not refused as documented: rc {r.returncode}, {r.stderr!r}")
    for missing in [p for p in ("avx512", "avx2") if p not in paths]:
        r = run(insid, ["--version"], cpu=missing, check=False)
        if r.returncode == 0 or "this CPU lacks" not in r.stderr:
            failures.append(f"INSID_CPU={missing} on a CPU without it: rc {r.returncode}, {r.stderr!r}")
    # The same refusal on this CPU, with the paths it has hidden from insid's probe, and the
    # automatic choice falls back to the next path.
    for hidden in [p for p in ("avx512", "avx2") if p in paths]:
        hide = ",".join(paths[: paths.index(hidden) + 1])
        r = run(insid, ["--version"], cpu=hidden, hide=hide, check=False)
        if r.returncode == 0 or f"INSID_CPU={hidden}: this CPU lacks" not in r.stderr:
            failures.append(f"INSID_CPU={hidden} with INSID_CPU_HIDE={hide}: rc {r.returncode}, {r.stderr!r}")
        fallback = paths[paths.index(hidden) + 1]
        v = run(insid, ["--version"], hide=hide).stdout
        if f"CPU path:     {fallback} " not in v:
            failures.append(f"INSID_CPU_HIDE={hide}: expected the automatic choice {fallback}, --version says:\n{v}")
    r = run(insid, ["--version"], hide="baseline", check=False)
    if r.returncode == 0 or "is not a path that can be hidden" not in r.stderr:
        failures.append(f"INSID_CPU_HIDE=baseline not refused: rc {r.returncode}, {r.stderr!r}")

    results = {}
    for p in paths:
        v = run(insid, ["--version"], cpu=p).stdout
        if f"CPU path:     {p} " not in v:
            failures.append(f"INSID_CPU={p}: --version does not name it:\n{v}")
        per_threads = {}
        for t in (1, 2):
            out = os.path.join(work, f"{p}-{t}")
            run(insid, ["navigate", "--data", data, "--summary", out + "-nav.json"], cpu=p, threads=t)
            run(insid, ["identify", "--data", data, "--algo", "dvpio", "--iterations", "4", "--seed", "3",
                        "--no-reference-optimum", "--uncertainty-replicas", "0", "--out", out + "-id.json"],
                cpu=p, threads=t)
            nav = json.load(open(out + "-nav.json"))
            ident = json.load(open(out + "-id.json"))
            if not ident["build"]["cpu_path"].startswith(p + " "):
                failures.append(f"{p}: the result's build block says {ident['build']['cpu_path']!r}")
            per_threads[t] = (nav["fitness"], ident["fitness"], ident["best_per_evaluation"],
                              ident["search_fitness"]["used"])
        if per_threads[1] != per_threads[2]:
            failures.append(f"{p}: 1 and 2 threads differ: {per_threads[1][:2]} vs {per_threads[2][:2]}")
        results[p] = per_threads[1]
        print(f"{p}: navigate Eq. 15 {per_threads[1][0]!r}, DVPIO best {per_threads[1][1]!r}")
    ref = results[paths[0]]
    for p in paths[1:]:
        for name, a, b in (("navigate fitness", ref[0], results[p][0]),
                           ("identify fitness", ref[1], results[p][1])):
            if abs(a - b) > RTOL * abs(a):
                failures.append(f"{name}: {paths[0]} {a!r} vs {p} {b!r} (relative {abs(a - b) / abs(a):.2e})")
        worst = max(abs(x - y) / abs(x) for x, y in zip(ref[2], results[p][2]))
        tolerance = RTOL_FAST_SEARCH if ref[3] == "fast" else RTOL
        print(f"{p} vs {paths[0]}: worst relative difference over the DVPIO run's evaluations {worst:.2e}"
              f" ({ref[3]} search fitness, tolerance {tolerance:.1e})")
        if worst > tolerance:
            failures.append(f"identify best-so-far trace: {p} differs from {paths[0]} by {worst:.2e} relative")
    if failures:
        print("FAIL:\n  " + "\n  ".join(failures))
        return 1
    print(f"cpu paths {', '.join(paths)}: same results within {RTOL:g}, same bits for 1 and 2 threads")
    return 0


if __name__ == "__main__":
    sys.exit(main())
