#!/usr/bin/python3
"""Where a campaign's threads wait, round by round, and what that predicts for more threads.

Reads the round logs of `insid bench --round-log FILE` (one JSON line per lock-step round:
candidates asked and scored, scoring and round wall time) and the phase rows of scripts/perf_phases.py for the
same campaign at several thread counts (used by scripts/perf_phases.sh; usable alone):

  scripts/perf_rounds.py --phases results/perf/phases.jsonl \\
      --log 1=/tmp/r1.jsonl --log 2=/tmp/r2.jsonl --log 16=/tmp/r16.jsonl

The model. A round's scored candidates (a candidate that repeats one already scored is not scored
again, opt::FitnessMemo; a log from before that has no "scored": all count) go into SIMD vectors of 8 lanes; the batched kernel packs the
vectors into groups (BatchFitness::plan_groups, kernel/batch_fitness.cc: two vectors a group on the
AVX-512 path, more groups of one vector when there are fewer groups than threads) and the threads
take the groups one at a time (OpenMP dynamic schedule), so a round's scoring lasts as long as the
busiest thread: the critical path of greedy list scheduling. A two-vector group costs c, a
one-vector group c1 = --one-vector-cost * c / 2 (one vector alone hides less latency; 1.12 is
BM_FitnessBatched K = 8 against K = 16 at one thread, results/perf/microbench.json).
c is fitted to the 1-thread log (its scoring time over its groups). The rest of the wall time is
taken as serial and as long at any thread count: each round's time outside scoring (asks, tells,
run files) and the time outside rounds (waves made, optimum collected, summary). The simulation
before the runs is split into a serial and a parallel part by its times at 1 and 2 threads. The
optimum, found beside the runs, adds its 1-thread time spread over the threads.

The prediction for T threads takes the rounds of a campaign run at T threads, which may run on
2 cores: for paper-fig9 at 16 threads the wave target, wave_target(16, 124 runs) = max(48 x 16,
20 x 124 / 8) = 768 candidates a round, is also the smallest wave, so the waves (and rounds) do
not depend on the machine's speed. The group costs come from 1 thread, the rest from 2 threads. It assumes a core at T threads is as fast as at
1: no shared-cache, memory-bandwidth or clock effects. (Each group streams the flight's IMU rows
from memory, about 40 MB per pass at paper-fig9's 860 000 steps; the per-step state is in L1.)
"""
import argparse, json, math, sys

LANES = 8


def scored(round_row):
    """Candidates the round scored (a log from before FitnessMemo: all it asked)."""
    return round_row.get("scored", round_row["candidates"])


def plan_groups(num_vectors, threads, planned_chains=2):
    """BatchFitness::plan_groups (kernel/batch_fitness.cc), the same arithmetic."""
    if num_vectors <= 0:
        return []
    threads = max(threads, 1)
    g = (num_vectors + planned_chains - 1) // planned_chains
    if threads > 1:
        g = max(g, min(num_vectors, threads))
        g = min(num_vectors, ((g + threads - 1) // threads) * threads)
    return [num_vectors // g + (1 if i < num_vectors % g else 0) for i in range(g)]


def group_cost(vectors, c2, c1):
    # Groups hold one or two vectors (kMaxChains = 2).
    return c2 if vectors == 2 else c1 * vectors


def critical_path(groups, threads, c2, c1):
    """Greedy list scheduling in group order (schedule(dynamic, 1)): each group to the thread
    that is free first; the round lasts until the last thread is done."""
    free = [0.0] * min(threads, max(len(groups), 1))
    for g in groups:
        i = free.index(min(free))
        free[i] += group_cost(g, c2, c1)
    return max(free) if free else 0.0


def read_log(path):
    rows = [json.loads(l) for l in open(path) if l.strip()]
    if not rows:
        sys.exit(f"perf_rounds: {path}: no rounds")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--phases", required=True, help="phase rows (JSON lines of scripts/perf_phases.py)")
    ap.add_argument("--log", action="append", default=[], metavar="T=FILE",
                    help="round log of the campaign at T threads (1 and 2 needed; more to predict)")
    ap.add_argument("--one-vector-cost", type=float, default=1.12,
                    help="cost of a vector in a one-vector group over one in a two-vector group")
    ap.add_argument("--predict", default="4 8 16", help="thread counts to predict (default '4 8 16')")
    a = ap.parse_args()

    phases = {}
    for line in open(a.phases):
        if line.strip():
            r = json.loads(line)
            phases[r["threads"]] = r
    logs = {}
    for spec in a.log:
        t, _, path = spec.partition("=")
        if not t.isdigit() or not path:
            sys.exit(f"perf_rounds: --log {spec}: expected T=FILE")
        logs[int(t)] = read_log(path)
    for t in (1, 2):
        if t not in logs or t not in phases:
            sys.exit(f"perf_rounds: need the round log and the phase row at {t} thread(s)")

    # Cost of a two-vector group [s], from the 1-thread log: its groups are all of two vectors
    # but for a one-vector group in a round with an odd vector count.
    units = 0.0
    scoring1 = 0.0
    for r in logs[1]:
        nv = math.ceil(scored(r) / LANES)
        units += sum(1.0 if g == 2 else a.one_vector_cost * g / 2.0 for g in plan_groups(nv, 1))
        scoring1 += r["scoring_s"]
    c2 = scoring1 / units
    c1 = a.one_vector_cost * c2 / 2.0

    def parts(t):
        """Measured parts of the campaign at t threads [s]."""
        p, rows = phases[t], logs[t]
        sim = p.get("optimum_start") or 0.0
        scoring = sum(r["scoring_s"] for r in rows)
        in_rounds = sum(r["round_s"] for r in rows)
        return {"sim": sim, "scoring": scoring, "round_rest": in_rounds - scoring,
                "outside": p["wall_s"] - sim - in_rounds, "wall": p["wall_s"],
                "rounds": len(rows), "candidates": sum(r["candidates"] for r in rows),
                "scored": sum(scored(r) for r in rows)}

    def modelled_scoring(rows, t):
        ideal = crit = 0.0
        for r in rows:
            groups = plan_groups(math.ceil(scored(r) / LANES), t)
            crit += critical_path(groups, t, c2, c1)
            ideal += sum(group_cost(g, c2, c1) for g in groups) / t
        return crit, ideal

    p1, p2 = parts(1), parts(2)
    opt1 = None
    if phases[1].get("optimum_done") and phases[1].get("optimum_start"):
        opt1 = phases[1]["optimum_done"] - phases[1]["optimum_start"]
    # The simulation before the runs (the IMU synthesis runs on the campaign's threads): its
    # serial and parallel parts from 1 and 2 threads, sim(T) = s + p / T.
    sim_parallel = max(0.0, 2.0 * (p1["sim"] - p2["sim"]))
    sim_serial = p1["sim"] - sim_parallel
    sim_at = lambda t: sim_serial + sim_parallel / t
    rest = p2["round_rest"] + p2["outside"]
    serial = sim_at(2) + rest
    out = []
    out.append(f"Round model (scripts/perf_rounds.py): a two-vector group costs {1e3 * c2:.3f} ms, a one-vector "
               f"group {1e3 * c1:.3f} ms (fitted to the {p1['rounds']} rounds at 1 thread).")
    out.append("")
    out.append("| threads | rounds | candidates (scored) | scoring measured | scoring modelled (critical path / even split) | "
               "rounds' rest | outside rounds | sim | wall |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for t in sorted(logs):
        crit, ideal = modelled_scoring(logs[t], t)
        if t in phases:
            p = parts(t)
            out.append(f"| {t} | {p['rounds']} | {p['candidates']} ({p['scored']}) | {p['scoring']:.1f} | {crit:.1f} / {ideal:.1f} | "
                       f"{p['round_rest']:.1f} | {p['outside']:.1f} | {p['sim']:.1f} | {p['wall']:.1f} |")
    out.append("")
    crit2, ideal2 = modelled_scoring(logs[2], 2)
    out.append(f"At 2 threads: scoring measured {p2['scoring']:.1f} s against {crit2:.1f} s modelled "
               f"({100 * (p2['scoring'] / crit2 - 1):+.1f} %); waiting on the busiest thread costs "
               f"{crit2 - ideal2:.1f} s ({100 * (crit2 / ideal2 - 1):.1f} % of an even split); rounds' rest "
               f"{p2['round_rest']:.1f} s and outside rounds {p2['outside']:.1f} s. The simulation took "
               f"{p1['sim']:.1f} s at 1 thread and {p2['sim']:.1f} s at 2: {sim_serial:.1f} s serial + "
               f"{sim_parallel:.1f} s / threads.")
    opt_share = lambda t: (opt1 / t if opt1 else 0.0)
    t2_model = serial + crit2 + opt_share(2)
    out.append(f"Modelled wall at 2 threads: {t2_model:.1f} s (measured {p2['wall']:.1f} s).")
    for t in [int(x) for x in a.predict.split()]:
        if t not in logs:
            out.append(f"{t} threads: no round log at {t} threads; not predicted.")
            continue
        crit, ideal = modelled_scoring(logs[t], t)
        wall = sim_at(t) + rest + crit + opt_share(t)
        out.append(f"{t} threads: scoring {crit:.1f} s (even split {ideal:.1f} s) + simulation {sim_at(t):.1f} s + "
                   f"rest {rest:.1f} s + optimum {opt_share(t):.1f} s = {wall:.1f} s; T(2)/T({t}) = "
                   f"{t2_model / wall:.2f}x modelled, {p2['wall'] / wall:.2f}x from the measured T(2).")
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
