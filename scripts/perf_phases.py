#!/usr/bin/python3
"""Measure the phases of one `insid bench` campaign (used by scripts/perf_phases.sh).

Starts the campaign into a fresh directory, stamps each progress line on stderr as it arrives
and reads the finish times of the files the campaign writes (optimum/, runs/, summary.json), then
prints one JSON line: the thread count, the total wall time and the phases, in seconds from the
start of the process:
  prepare_start  "preparing scenario" (the directory is checked and the manifest written)
  optimum_start  "finding the data's own optimum" (the flight is simulated; absent when cached)
  optimum_done   optimum/<scenario>.json written
  first_run      the first run file written
  last_run       the last run file written
  exit           the process ended (summary written)
"""
import json, os, subprocess, sys, tempfile, time, glob

def main():
    binary, threads, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    extra = sys.argv[4:]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = [binary, "bench", "--out", out, "--threads", str(threads)] + extra
    t0 = time.time()
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, env=env)
    stamps = {}
    line = b""
    while True:
        c = proc.stderr.read1(4096) if hasattr(proc.stderr, "read1") else proc.stderr.read(1)
        if not c:
            break
        now = time.time() - t0
        line += c
        for key, text in (("prepare_start", b"preparing scenario"),
                          ("optimum_start", b"finding the data's own optimum")):
            if key not in stamps and text in line:
                stamps[key] = now
        line = line[-400:]
    rc = proc.wait()
    t_exit = time.time() - t0
    if rc != 0:
        sys.exit(f"perf_phases: {' '.join(cmd)} failed with status {rc}")
    def mtime(p):
        return os.stat(p).st_mtime_ns / 1e9 - t0
    opt = glob.glob(os.path.join(out, "optimum", "*.json"))
    runs = sorted(mtime(p) for p in glob.glob(os.path.join(out, "runs", "**", "*.json"), recursive=True))
    result = {"threads": threads, "wall_s": t_exit, "runs": len(runs), **stamps,
              "optimum_done": max(mtime(p) for p in opt) if opt else None,
              "first_run": runs[0] if runs else None, "last_run": runs[-1] if runs else None,
              "exit": t_exit}
    print(json.dumps(result))

main()
