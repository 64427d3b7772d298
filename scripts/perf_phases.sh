#!/usr/bin/env bash
# Phases of the main job's campaign and the serial fraction they imply.
#   scripts/perf_phases.sh                      # paper-fig9, 31 seeds, threads 1 2 4
#   scripts/perf_phases.sh --seeds 5 --threads "2"
#   scripts/perf_phases.sh --bin /path/to/other/insid --out results/perf/phases-before.md
# For each thread count, runs `insid bench --preset paper-fig9 --seeds N --threads T` (and
# OMP_NUM_THREADS=T) into a fresh temporary directory, timing each phase (scripts/perf_phases.py:
# progress lines stamped on arrival, the finish times of the optimum and run files), then
# writes a Markdown table and the Amdahl prediction to --out (default results/perf/phases.md)
# and the raw measurements to the same name with .jsonl. With 31 seeds the summary of every
# campaign is also compared with the committed results/paper-fig9-31/summary.json, all but
# wall times (the script lists the first differences and fails when they differ); each
# campaign's summary is kept as <out>-t<threads>-summary.json, its round log (insid bench
# --round-log) as <out>-rounds-t<threads>.jsonl; with 1 and 2 among the thread counts the round
# model of scripts/perf_rounds.py is appended to --out (it predicts the largest counts given).
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=31
threads="1 2 4"
bin=build/cli/insid
out=results/perf/phases.md
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) seeds="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    *) echo "perf_phases.sh: unknown option '$1' (expected --seeds N, --threads \"T ...\", --bin PATH, --out FILE)" >&2; exit 2 ;;
  esac
done
[ -x "$bin" ] || { echo "perf_phases.sh: no insid binary at '$bin' (build it, or give --bin)" >&2; exit 2; }
raw="${out%.md}.jsonl"
mkdir -p "$(dirname "$out")"
: > "$raw"
status=0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for t in $threads; do
  echo "perf_phases.sh: paper-fig9, $seeds seeds, $t thread(s) ..." >&2
  rounds="${out%.md}-rounds-t$t.jsonl"
  rm -f "$rounds"
  /usr/bin/python3 scripts/perf_phases.py "$bin" "$t" "$work/c$t" --preset paper-fig9 --seeds "$seeds" \
    --round-log "$rounds" >> "$raw"
  cp "$work/c$t/summary.json" "${out%.md}-t$t-summary.json"
  if [ "$seeds" = 31 ]; then
    /usr/bin/python3 - "$work/c$t/summary.json" results/paper-fig9-31/summary.json <<'PY' || status=1
import json, lzma, os, sys
def lean(v):
    if isinstance(v, dict):
        return {k: lean(x) for k, x in v.items() if k not in ("curve_evaluations", "curve_iterations")}
    return [lean(x) for x in v] if isinstance(v, list) else v
def load(p):  # a committed summary packed by scripts/pack_results.py: whole in NAME.full.json.xz
    with open(p) as f:
        plain = json.load(f)
    full = p[:-len(".json")] + ".full.json.xz"
    if os.path.exists(full):
        with lzma.open(full, "rt") as f:
            whole = json.load(f)
        if lean(whole) == plain:
            return whole
    return plain
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k != "wall_s"}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
differences = []
def diff(x, y, path):
    if isinstance(x, dict) and isinstance(y, dict):
        for k in sorted(set(x) | set(y)):
            if k not in x or k not in y:
                differences.append(f"{path}/{k}: only in one")
            else:
                diff(x[k], y[k], f"{path}/{k}")
    elif isinstance(x, list) and isinstance(y, list) and len(x) == len(y):
        for i, (p, q) in enumerate(zip(x, y)):
            diff(p, q, f"{path}[{i}]")
    elif x != y:
        differences.append(f"{path}: {x!r} vs {y!r}")
a, b = (strip(load(p)) for p in sys.argv[1:3])
diff(a, b, "")
if differences:
    print(f"perf_phases.sh: {len(differences)} values of {sys.argv[1]} differ from {sys.argv[2]} "
          "(wall times aside), e.g.:\n  " + "\n  ".join(differences[:5]), file=sys.stderr)
    sys.exit(1)
print(f"perf_phases.sh: summary equals {sys.argv[2]} (wall times aside)", file=sys.stderr)
PY
  fi
  rm -rf "$work/c$t"
done
/usr/bin/python3 - "$raw" "$out" "$seeds" "$bin" <<'PY'
import json, os, platform, subprocess, sys, time
raw, out, seeds, binary = sys.argv[1:5]
rows = [json.loads(l) for l in open(raw) if l.strip()]
def f(v):
    return "-" if v is None else f"{v:.1f}"
cpu = "unknown CPU"
try:
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip(); break
except OSError:
    pass
load = os.getloadavg()
lines = [
    f"# Phases of `insid bench --preset paper-fig9 --seeds {seeds}`",
    "",
    f"Measured by `scripts/perf_phases.sh` on {platform.node()} ({os.cpu_count()} logical CPUs, {cpu}),",
    f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, binary `{binary}`; load average at the end "
    f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min: other processes share the cores).",
    "Times in seconds from the start of the process: `sim` = the flight simulated (the line",
    "\"finding the data's own optimum\"), `opt` = optimum/<scenario>.json written, `first` / `last` =",
    "the first / last run file written, `wall` = the process ended (summary written).",
    "",
    "| threads | sim | opt | first run | last run | wall | runs |",
    "|---|---|---|---|---|---|---|",
]
for r in rows:
    lines.append(f"| {r['threads']} | {f(r.get('optimum_start'))} | {f(r.get('optimum_done'))} | "
                 f"{f(r.get('first_run'))} | {f(r.get('last_run'))} | {f(r['wall_s'])} | {r['runs']} |")
by_t = {r["threads"]: r for r in rows}
lines.append("")
if 1 in by_t and 2 in by_t:
    t1, t2 = by_t[1]["wall_s"], by_t[2]["wall_s"]
    s = 2.0 * t2 / t1 - 1.0  # Amdahl: T(n) = T(1) (s + (1 - s) / n)
    lines.append(f"Amdahl from the wall times at 1 and 2 threads: T(2)/T(1) = {t2 / t1:.3f}, serial fraction "
                 f"s = 2 T(2)/T(1) - 1 = {s:.3f}.")
    if 0.0 <= s < 1.0:
        pred = lambda n: s + (1.0 - s) / n
        lines.append(f"Predicted speed-up from 2 to 16 threads: T(2)/T(16) = {pred(2) / pred(16):.2f}x "
                     f"(2 to 8: {pred(2) / pred(8):.2f}x).")
    else:
        lines.append("(s outside [0, 1): the two runs saw different machine loads; no prediction.)")
    # The serial phase measured directly: the simulation, before which no thread has work.
    sim = by_t[1].get("optimum_start")
    if sim is not None:
        ss = sim / t1
        pred = lambda n: ss + (1.0 - ss) / n
        lines.append(f"From the phases at 1 thread: the simulation ({sim:.1f} s) is {100 * ss:.1f} % of T(1); with "
                     f"everything else parallel that predicts T(2)/T(16) = {pred(2) / pred(16):.2f}x.")
    # The optimum is found beside the runs; at 1 thread it has the second core to itself, so its
    # duration there is its serial cost. At 16 threads its starts run 4 at a time
    # (bench/lockstep_runner.cc): it stays off the critical path while it ends before the runs.
    r1 = by_t[1]
    if r1.get("optimum_start") is not None and r1.get("optimum_done") is not None:
        opt1 = r1["optimum_done"] - r1["optimum_start"]
        runs16 = (t1 - r1["optimum_start"]) / 16.0
        lines.append(f"The optimum took {opt1:.1f} s at 1 thread (its four starts one after another, on the "
                     f"other core). At 16 threads they run four at once: about {opt1 / 4:.1f} s if the starts "
                     f"cost the same, against {runs16:.1f} s for the runs at a perfect 16x "
                     f"({'off' if opt1 / 4 < runs16 else 'ON'} the critical path; one start after another "
                     f"it would be {'off' if opt1 < runs16 else 'on'} it).")
if 2 in by_t and by_t[2].get("optimum_start") is not None:
    r = by_t[2]
    lines.append(f"At 2 threads the runs start {r['optimum_start']:.1f} s after the process ({100 * r['optimum_start'] / r['wall_s']:.1f} % "
                 f"of the wall time).")
lines.append("")
open(out, "w").write("\n".join(lines))
print("\n".join(lines))
PY
# Round by round (scripts/perf_rounds.py): where the threads wait, and the prediction from the
# rounds of the largest thread count measured (e.g. --threads "1 2 16" on 2 cores).
logs=()
for t in $threads; do logs+=(--log "$t=${out%.md}-rounds-t$t.jsonl"); done
if [[ " $threads " == *" 1 "* && " $threads " == *" 2 "* ]]; then
  { echo; /usr/bin/python3 scripts/perf_rounds.py --phases "$raw" "${logs[@]}" --predict "$threads"; } | tee -a "$out"
fi
exit $status
