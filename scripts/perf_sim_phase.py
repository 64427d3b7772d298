#!/usr/bin/python3
"""Time the serial start of the main job: two insid binaries, alternating.

  scripts/perf_sim_phase.py --threads 2 --pairs 4 old=/path/to/insid new=build/cli/insid

For each pair, runs `insid bench --preset paper-fig9 --seeds 31 --threads T` (OMP_NUM_THREADS=T)
of each binary into a fresh temporary directory, stamps the progress line "finding the data's
own optimum" (the flight simulated: nothing before it runs on more than the simulation's threads),
then kills the process. Prints one JSON line per run: binary name, pair, threads, sim_s.
A binary whose folder holds a lib/ folder gets it first on LD_LIBRARY_PATH (a bundle carried to
another machine with the shared libraries `ldd` lists; results/perf/xeon16/README.md).
"""
import argparse, json, os, shutil, subprocess, tempfile, time


def sim_seconds(binary, threads):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    lib = os.path.join(os.path.dirname(os.path.abspath(binary)), "lib")
    if os.path.isdir(lib):
        env["LD_LIBRARY_PATH"] = lib + os.pathsep + env.get("LD_LIBRARY_PATH", "")
    work = tempfile.mkdtemp()
    try:
        t0 = time.time()
        proc = subprocess.Popen([binary, "bench", "--preset", "paper-fig9", "--seeds", "31",
                                 "--threads", str(threads), "--out", os.path.join(work, "c")],
                                stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, env=env)
        seen, stamp = b"", None
        while stamp is None:
            chunk = proc.stderr.read1(4096)
            if not chunk:
                break
            seen = (seen + chunk)[-400:]
            if b"finding the data's own optimum" in seen:
                stamp = time.time() - t0
        proc.kill()
        proc.wait()
        if stamp is None:
            raise SystemExit(f"perf_sim_phase: {binary} ended (status {proc.returncode}) before "
                             "its simulation finished")
        return stamp
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--pairs", type=int, default=4)
    parser.add_argument("binaries", nargs="+", metavar="NAME=PATH")
    args = parser.parse_args()
    binaries = []
    for item in args.binaries:
        name, sep, path = item.partition("=")
        if not sep or not os.access(path, os.X_OK):
            parser.error(f"'{item}': expected NAME=PATH to an insid binary")
        binaries.append((name, path))
    for pair in range(args.pairs):
        for name, path in binaries:
            print(json.dumps({"binary": name, "pair": pair, "threads": args.threads,
                              "sim_s": sim_seconds(path, args.threads)}), flush=True)


main()
