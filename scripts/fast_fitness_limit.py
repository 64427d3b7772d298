#!/usr/bin/python3
"""The fast search fitness's loop against this core's limit (issue 47;
results/perf/fast-fitness/limit.md), as scripts/kernel_limit.py does for the exact kernel.

    scripts/fast_fitness_limit.py [--build build] [--out results/perf/fast-fitness] [--repetitions 5]

1. Counts the operations of the loop as compiled: perf samples (cpu-clock) of `insid-microbench`
   on BM_SearchFitness/fast (32 candidates, one thread, AVX-512 path), the hottest loop of
   kernel_avx512's sum_norms (its epoch loop); one iteration holds (vsqrtpd count) / 2 epochs of
   16 candidates (two 8-lane vectors per epoch).
2. Runs the square-root probe (BM_Pipe/sqrt: independent 512-bit vsqrtpd), the FMA probe and the
   fast fitness in one Google Benchmark run, medians of the repetitions.
3. Writes limit.md and limit.json: ns per candidate-epoch at the square-root limit (roots per
   candidate-epoch / root rate) and at the FMA-pipe limit (mul + add + FMA per candidate-epoch /
   FMA rate, the adds sharing those pipes), and the measured loop as a fraction of the larger.
"""
import argparse
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from kernel_limit import (annotated, basic_blocks, benchmark_medians, count,  # noqa: E402
                          microbench, write_limit)

FUNC = "kernel_avx512::(anonymous namespace)::sum_norms"
LANES = 16  # two vectors of 8 doubles per epoch


def hottest_loop(rows):
    """(head, tail) of the innermost loop holding at least half of the function's samples (the
    epoch loop, inside the loop over blocks), and its share."""
    total = sum(r[0] for r in rows)
    spans = []
    for _, a, op, arg in rows:
        if not op.startswith("j"):
            continue
        m = re.match(r"([0-9a-f]+)", arg)
        if m and int(m.group(1), 16) < a:
            t = int(m.group(1), 16)
            spans.append((a - t, (t, a), sum(r[0] for r in rows if t <= r[1] <= a)))
    hot = [s for s in spans if s[2] >= 0.5 * total]
    if not hot:
        sys.exit("fast_fitness_limit.py: no loop holds half of the samples")
    _, loop, share = min(hot)
    return loop, share


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="results/perf/fast-fitness")
    ap.add_argument("--repetitions", type=int, default=5)
    a = ap.parse_args()
    bench = microbench(a.build, "fast_fitness_limit.py")
    avx512 = {**os.environ, "INSID_CPU": "avx512"}
    rows, share_of_run = annotated(bench, "SearchFitness/fast", FUNC, "fast_fitness_limit.py",
                                   avx512)
    (lo, hi), loop_share = hottest_loop(rows)
    instrs = [r for b in basic_blocks(rows, lo, hi) for r in b]
    c = count(instrs)
    if c["sqrt"] == 0 or c["sqrt"] % 2:
        sys.exit(f"fast_fitness_limit.py: the hottest loop {lo:#x}-{hi:#x} holds {c['sqrt']} "
                 "512-bit square roots, not two per epoch")
    epochs = c["sqrt"] // 2
    per_candidate = {k: v / (epochs * LANES) for k, v in c.items()}
    fma_pipe_ops = c["fma"] + c["mul"] + c["add"]

    med = benchmark_medians(bench, "Pipe/(fma|sqrt)/|SearchFitness/fast", a.repetitions,
                            ("fma_zmm_per_ns", "div_zmm_per_ns", "ns_per_candidate_step"), avx512)
    sqrt_rate = med[("BM_Pipe/sqrt/real_time", "div_zmm_per_ns")]
    fma_rate = med[("BM_Pipe/fma/real_time", "fma_zmm_per_ns")]
    measured = next(v for (k, counter), v in med.items()
                    if k.startswith("BM_SearchFitness/fast") and counter == "ns_per_candidate_step")
    limit_sqrt = c["sqrt"] / (epochs * LANES) / sqrt_rate
    limit_fma = fma_pipe_ops / (epochs * LANES) / fma_rate
    limit = max(limit_sqrt, limit_fma)
    res = {
        "loop": {"address": f"{lo:#x}-{hi:#x}", "samples_percent_of_function": round(loop_share, 1),
                 "function_percent_of_run": share_of_run, "epochs_per_iteration": epochs,
                 "ops_per_iteration": c},
        "per_candidate_epoch": per_candidate,
        "probes": {"sqrt_zmm_per_ns": sqrt_rate, "fma_zmm_per_ns": fma_rate},
        "limits_ns_per_candidate_epoch": {"square_root": limit_sqrt, "fma_pipes": limit_fma},
        "measured_ns_per_candidate_epoch": measured,
        "fraction_of_limit": limit / measured,
        "repetitions": a.repetitions,
    }
    lines = [
        "# The fast search fitness's loop against this core's limit",
        "",
        "Written by `scripts/fast_fitness_limit.py` (counts from the compiled epoch loop of "
        f"`{FUNC}`, AVX-512 path; probes and the fast fitness in one `insid-microbench` run, "
        f"medians of {a.repetitions} repetitions).",
        "",
        f"- the loop ({lo:#x}-{hi:#x}, {loop_share:.0f} % of the function's samples, the function "
        f"{share_of_run:.0f} % of the run) does {epochs} epoch(s) of {LANES} candidates per "
        f"iteration: {c['instructions']} instructions, {c['sqrt']} vsqrtpd, {c['mul']} vmulpd, "
        f"{c['add']} vaddpd/vsubpd, {c['fma']} FMA, {c['loads']} loads",
        f"- per candidate-epoch: {per_candidate['instructions']:.2f} instructions, "
        f"{per_candidate['sqrt']:.3f} square roots, {fma_pipe_ops / (epochs * LANES):.3f} "
        "FMA-pipe operations (512-bit)",
        f"- probes: {sqrt_rate:.3f} square roots per ns, {fma_rate:.2f} FMAs per ns",
        f"- limits: square root **{limit_sqrt:.3f} ns** per candidate-epoch, FMA pipes "
        f"{limit_fma:.3f} ns",
        f"- measured: {measured:.3f} ns per candidate-epoch, **{100 * limit / measured:.0f} %** of "
        "the limit",
        "",
    ]
    write_limit(a.out, res, lines)


if __name__ == "__main__":
    main()
