#!/usr/bin/python3
"""irace target runner for insid: one optimizer run on one (configuration, instance), prints its cost.

irace calls the runner written by scripts/irace_tune.py (OUT/target-runner), which execs

  /usr/bin/python3 scripts/irace_target_runner.py --insid BIN --evaluations E [--iterations I]
      [--identify-arg ARG ...] -- CONFIG_ID INSTANCE_ID SEED INSTANCE SWITCHES...

where CONFIG_ID INSTANCE_ID SEED INSTANCE SWITCHES are irace's own arguments (irace 3.x, no
capping bound): INSTANCE is a dataset directory (a simulated flight with one noise seed), SEED
is the optimizer's seed and SWITCHES are the parameter file's switches with their values
(`--algo dvpio --param R=0.05 --param d_initial_sigma=0.05 ...`).

It runs exactly

  insid identify --data INSTANCE --seed SEED SWITCHES --iterations I --evaluations E
      --uncertainty-replicas 0 --threads 1 --quiet --out TMP.json [IDENTIFY_ARGS]

and prints one line: the run's cost, `fitness_gap_relative` of the result JSON, i.e.
(f_best - f_opt) / f_opt with f the final Eq. 15 fitness and f_opt the data's own optimum
(identify's multi-start local fit, cached in INSTANCE/insid-optimum-cache.json: irace_tune.py
fills that cache before irace starts, so no call searches the optimum or simulates anything).
The cost is printed with repr() (17 significant digits), so it is the JSON's double exactly.

Why this cost (and not the error vs optimum in sigma): it is what the optimizer minimises and
sees, one number per run with no choice of norm; relative to the optimum it is comparable across
flights and noise seeds (Eq. 15 grows with the flight length and the GNSS rate). The error in
sigma is dominated by the weakly observable gyro biases, whose error a flat fitness valley
leaves to chance (README "Which estimator to trust").

Exit status 0 with the cost on stdout; 1 with a message on stderr naming the configuration,
instance and seed when insid fails or the result has no cost (irace then stops and shows it).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--insid", required=True, help="the insid binary")
    ap.add_argument("--evaluations", type=int, required=True, help="INS runs per optimizer run")
    ap.add_argument("--iterations", type=int, default=0, help="iteration budget (0 = none)")
    ap.add_argument("--identify-arg", action="append", default=[],
                    help="one more argument for insid identify (repeatable)")
    ap.add_argument("irace", nargs=argparse.REMAINDER,
                    help="-- CONFIG_ID INSTANCE_ID SEED INSTANCE SWITCHES...")
    args = ap.parse_args(argv)
    rest = args.irace[1:] if args.irace[:1] == ["--"] else args.irace
    if len(rest) < 4:
        sys.stderr.write("irace_target_runner: expected CONFIG_ID INSTANCE_ID SEED INSTANCE "
                         "SWITCHES..., got %r\n" % (rest,))
        return 1
    config_id, instance_id, seed, instance = rest[:4]
    switches = rest[4:]
    with tempfile.TemporaryDirectory(prefix="insid-irace-") as tmp:
        out = os.path.join(tmp, "result.json")
        cmd = [args.insid, "identify", "--data", instance, "--seed", seed] + switches + [
            "--iterations", str(args.iterations), "--evaluations", str(args.evaluations),
            "--uncertainty-replicas", "0", "--threads", "1", "--quiet", "--out", out
        ] + args.identify_arg
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        where = "configuration %s, instance %s (%s), seed %s" % (config_id, instance_id, instance,
                                                                 seed)
        if proc.returncode != 0:
            sys.stderr.write("irace_target_runner: insid identify failed (exit %d) for %s:\n%s\n"
                             "command: %s\n" % (proc.returncode, where, proc.stderr.strip(),
                                                " ".join(cmd)))
            return 1
        try:
            with open(out) as f:
                cost = json.load(f)["fitness_gap_relative"]
            cost = float(cost)
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.stderr.write("irace_target_runner: no fitness_gap_relative in the result of %s "
                             "(%s)\n" % (where, e))
            return 1
    print(repr(cost))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
