#!/usr/bin/python3
"""The batched kernel against this core's limits (results/perf/README.md).

    scripts/kernel_limit.py [--build build] [--out results/perf] [--repetitions 5]

1. Counts the operations of the kernel's hot loops as compiled: perf samples (cpu-clock: no
   hardware counters are needed) of `insid-microbench` on K = 16 candidates, 1 thread, locate the
   loops of run_group<2, false, false> (phase A and phase B, kernel/batch_fitness.cc) by their back
   edges; basic blocks without a sample are left out (branches the benchmark never takes).
   Each loop iteration is one IMU step of 2 x 8 = 16 candidates.
2. Runs the pipe probes (BM_Pipe/*: 512-bit FMA throughput alone and with the kernel's load,
   store and add traffic, divider throughput) and the kernel in one Google Benchmark run, medians
   of the repetitions, so that clock and load cancel in the ratios.
3. Writes limit.md and limit.json: ns per candidate-step at the FMA-pipe limit (FMA-pipe
   operations / FMA rate), at the limit of the kernel's instruction mix (the kernel_mix probe),
   the divider's share, and the measured kernel as a fraction of each.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

FUNC = "run_group<2, false, false>"
LANES_PER_STEP = 16  # 2 vectors of 8 doubles


def classify(op):
    if re.match(r"vf(n)?m(add|sub)", op):
        return "fma"
    if op.startswith("vmul"):
        return "mul"
    if op.startswith(("vadd", "vsub")):
        return "add"
    if op.startswith("vdiv"):
        return "div"
    if op.startswith("vsqrt"):
        return "sqrt"
    return "other"



def parse_annotate(text):
    rows = []
    for line in text.splitlines():
        m = re.match(r"\s*([0-9.]+)\s*:\s*([0-9a-f]+):\s+(\S+)\s*(.*)", line)
        if m:
            rows.append((float(m.group(1)), int(m.group(2), 16), m.group(3), m.group(4)))
    return rows


def loops(rows):
    """(head, tail) of backward branches spanning > 300 bytes, innermost first."""
    out = set()
    for _, a, op, arg in rows:
        if op.startswith("j"):
            m = re.match(r"([0-9a-f]+)", arg)
            if m:
                t = int(m.group(1), 16)
                if t < a and a - t > 300:
                    out.add((t, a))
    return sorted(out, key=lambda x: x[1] - x[0])


def basic_blocks(rows, lo, hi):
    region = [r for r in rows if lo <= r[1] <= hi]
    targets = set()
    for _, _, op, arg in region:
        if op.startswith("j"):
            m = re.match(r"([0-9a-f]+)", arg)
            if m:
                targets.add(int(m.group(1), 16))
    blocks, cur = [], []
    for r in region:
        if r[1] in targets and cur:
            blocks.append(cur)
            cur = []
        cur.append(r)
        if r[2].startswith("j"):
            blocks.append(cur)
            cur = []
    if cur:
        blocks.append(cur)
    return blocks


def block_densities(rows, lo, hi):
    return [sum(x[0] for x in b) / len(b) for b in basic_blocks(rows, lo, hi)]


def hot_blocks(rows, lo, hi, min_density):
    """Instructions of [lo, hi] in basic blocks with at least min_density samples per
    instruction (percent), i.e. run about once per step."""
    return [r for b in basic_blocks(rows, lo, hi)
            if sum(x[0] for x in b) > 0.0 and sum(x[0] for x in b) / len(b) >= min_density
            for r in b]


def count(instrs):
    c = {"fma": 0, "mul": 0, "add": 0, "div": 0, "sqrt": 0, "loads": 0, "stores": 0,
         "instructions": len(instrs)}
    for _, _, op, args in instrs:
        k = classify(op)
        if k != "other" and "zmm" in args:
            c[k] += 1
        if "(" in args:
            operands = [x.strip() for x in re.split(r",(?![^(]*\))", args)]
            if op.startswith("vmov") and "(" in operands[-1]:
                c["stores"] += 1
            elif "zmm" in args or op.startswith("vbroadcast"):
                c["loads"] += 1
    return c


def microbench(build, tool):
    """build/bench/insid-microbench, or exit naming `tool` and what to build."""
    bench = os.path.join(build, "bench", "insid-microbench")
    if not os.access(bench, os.X_OK):
        sys.exit(f"{tool}: {bench} not found: build the insid-microbench target first")
    return bench


def annotated(bench, benchmark_filter, func, tool, env=None):
    """perf samples (cpu-clock) of `bench` on `benchmark_filter`: the annotated rows of the first
    function whose name holds `func` (not one of its lambdas) and that function's percent of the
    run's samples."""
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "perf.data")
        subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "4000", "-o", data, bench,
                        f"--benchmark_filter={benchmark_filter}", "--benchmark_min_time=2"],
                       check=True, capture_output=True, env=env)
        sym = subprocess.run(["perf", "report", "-i", data, "--stdio", "--sort", "sym"],
                             check=True, capture_output=True, text=True).stdout
        shares = [(float(m.group(1)), m.group(2))
                  for m in re.finditer(r"([0-9.]+)%.*\[\.\]\s+(.*\S)", sym)]
        share, name = next(((p, n) for p, n in shares if func in n and "lambda" not in n),
                           (0.0, None))
        if name is None:
            sys.exit(f"{tool}: no samples in {func}; perf report:\n{sym[:2000]}")
        ann = subprocess.run(["perf", "annotate", "-i", data, "--stdio", "-s", name],
                             check=True, capture_output=True, text=True).stdout
    return parse_annotate(ann), share


def benchmark_medians(bench, benchmark_filter, repetitions, counters, env=None):
    """{(run name, counter): median over the repetitions} of one Google Benchmark run."""
    out = subprocess.run([bench, f"--benchmark_filter={benchmark_filter}",
                          f"--benchmark_repetitions={repetitions}", "--benchmark_format=json"],
                         check=True, capture_output=True, text=True, env=env).stdout
    med = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("run_type") != "iteration":
            continue
        for counter in counters:
            if counter in b:
                med.setdefault((b["run_name"], counter), []).append(b[counter])
    return {k: statistics.median(v) for k, v in med.items()}


def write_limit(out_dir, res, lines):
    """limit.json and limit.md in out_dir; the markdown printed too."""
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "limit.json"), "w") as f:
        json.dump(res, f, indent=2)
    with open(os.path.join(out_dir, "limit.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="results/perf")
    ap.add_argument("--repetitions", type=int, default=5)
    a = ap.parse_args()
    bench = microbench(a.build, "kernel_limit.py")
    rows, _ = annotated(bench, "FitnessBatched/K:16/threads:1/", FUNC, "kernel_limit.py")
    # Phase A: the shortest loop holding > 5 % of the samples. Phase B: the shortest loop beside it
    # holding > 40 % (the step loop) and the shorter hot loops beside both (the GNSS-epoch loop of
    # a step, placed out of line). Blocks run once per block of 16 steps or less often (anchors,
    # restarts) are told apart by their sample density (< 1/4 of the step loop's median).
    spans = [(lo, hi, sum(r[0] for r in rows if lo <= r[1] <= hi)) for lo, hi in loops(rows)]
    spans = [s for s in spans if s[2] > 5.0]
    if not spans:
        sys.exit("kernel_limit.py: no loop holds 5 % of the samples")
    a_lo, a_hi, _ = spans[0]
    beside = [(lo, hi, sh) for lo, hi, sh in spans if hi < a_lo or lo > a_hi]
    step = next(((lo, hi) for lo, hi, sh in beside if sh > 40.0), None)
    if step is None:
        sys.exit(f"kernel_limit.py: no phase-B loop beside phase A at {a_lo:#x}")
    b_parts = [step] + [(lo, hi) for lo, hi, _ in beside
                        if (hi - lo) < (step[1] - step[0]) and (hi < step[0] or lo > step[1])]
    density_ref = statistics.median(
        [d for d in block_densities(rows, *step) if d > 0.0])
    phases = {}
    for key, parts in (("A", [(a_lo, a_hi)]), ("B", b_parts)):
        instrs = []
        for lo, hi in parts:
            instrs += hot_blocks(rows, lo, hi, 0.25 * density_ref)
        c = count(instrs)
        c["samples_percent"] = round(sum(r[0] for r in instrs), 1)
        c["address"] = ", ".join(f"{lo:#x}-{hi:#x}" for lo, hi in parts)
        phases[key] = c
    total = {k: sum(p[k] for p in phases.values())
             for k in ("fma", "mul", "add", "div", "sqrt", "loads", "stores", "instructions")}
    fma_pipe_ops = total["fma"] + total["mul"]

    med = benchmark_medians(bench, "Pipe|FitnessBatched/K:(16|32)/threads:1/", a.repetitions,
                            ("fma_zmm_per_ns", "div_zmm_per_ns", "ns_per_candidate_step"))

    def rate(probe, counter="fma_zmm_per_ns"):
        return med[(f"BM_Pipe/{probe}/real_time", counter)]

    per_cand = {k: v / LANES_PER_STEP for k, v in total.items()}
    fma_rate, mix_rate, div_rate = rate("fma"), rate("kernel_mix"), rate("div", "div_zmm_per_ns")
    limit_fma = fma_pipe_ops / LANES_PER_STEP / fma_rate
    limit_mix = fma_pipe_ops / LANES_PER_STEP / mix_rate
    divider = (total["div"] + total["sqrt"]) / LANES_PER_STEP / div_rate
    kernel = {k: med[(f"BM_FitnessBatched/K:{k}/threads:1/min_time:2.000/real_time",
                      "ns_per_candidate_step")] for k in (16, 32)}
    res = {
        "machine": subprocess.run(["uname", "-m"], capture_output=True, text=True).stdout.strip(),
        "repetitions": a.repetitions,
        "ops_per_step_of_16_candidates": {"phase_A": phases["A"], "phase_B": phases["B"],
                                          "total": total},
        "per_candidate_step": {"fma_pipe_ops": fma_pipe_ops / LANES_PER_STEP,
                               "loads_per_fma_pipe_op": total["loads"] / fma_pipe_ops,
                               "stores_per_fma_pipe_op": total["stores"] / fma_pipe_ops,
                               "adds_per_fma_pipe_op": total["add"] / fma_pipe_ops},
        "probes": {"fma_zmm_per_ns": fma_rate, "kernel_mix_fma_zmm_per_ns": mix_rate,
                   "fma_load10_per_ns": rate("fma_load10"), "fma_store3_per_ns": rate("fma_store3"),
                   "fma_load10_store3_per_ns": rate("fma_load10_store3"),
                   "div_zmm_per_ns": div_rate},
        "limits_ns_per_candidate_step": {"fma_pipes": limit_fma, "kernel_instruction_mix": limit_mix,
                                         "divider_busy": divider},
        "kernel_ns_per_candidate_step": kernel,
        "fraction_of_fma_pipe_limit": {k: limit_fma / v for k, v in kernel.items()},
        "fraction_of_mix_limit": {k: limit_mix / v for k, v in kernel.items()},
    }
    lines = [
        "# The batched kernel against this core's limits",
        "",
        "Written by `scripts/kernel_limit.py` (counts from the compiled loops of "
        f"`{FUNC}`, probes and kernel in one `insid-microbench` run, medians of "
        f"{a.repetitions} repetitions).",
        "",
        "| per IMU step of 16 candidates | FMA | mul | add/sub | div | loads | stores | instructions |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, c in (("phase A", phases["A"]), ("phase B", phases["B"]), ("total", total)):
        lines.append(f"| {name} | {c['fma']} | {c['mul']} | {c['add']} | {c['div']} | "
                     f"{c['loads']} | {c['stores']} | {c['instructions']} |")
    lines += [
        "",
        f"- FMA-pipe operations (FMA + mul, 512-bit) per candidate-step: {fma_pipe_ops / 16:.2f}",
        f"- probes: FMA alone {fma_rate:.2f} per ns; with the kernel's mix of loads, stores and "
        f"adds {mix_rate:.2f} per ns; divider {div_rate:.3f} divisions per ns",
        f"- limit of the FMA pipes: **{limit_fma:.2f} ns** per candidate-step; limit of the "
        f"kernel's instruction mix: **{limit_mix:.2f} ns**; divider busy {divider:.2f} ns",
        f"- kernel K = 16: {kernel[16]:.2f} ns ({100 * limit_fma / kernel[16]:.0f} % of the FMA-pipe "
        f"limit, {100 * limit_mix / kernel[16]:.0f} % of the mix limit); K = 32: {kernel[32]:.2f} ns "
        f"({100 * limit_fma / kernel[32]:.0f} %, {100 * limit_mix / kernel[32]:.0f} %)",
        "",
    ]
    write_limit(a.out, res, lines)


if __name__ == "__main__":
    main()
